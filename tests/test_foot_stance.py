"""benchmarks/foot_stance.py: a tracked foot on tiptoe against a ground truth standing flat (made
from known poses, so the answer is known)."""
from __future__ import annotations

import csv
import importlib.util
import json
from pathlib import Path

import numpy as np
import pytest

from ipf_jax.body.model import DOF_INDEX, POINT_NAMES
from ipf_jax.body.shape import default_shape
from ipf_jax.data.runfiles import POSE_COLUMNS, write_rows
from ipf_jax.geometry.kinematics import forward_kinematics
from ipf_jax.geometry.posing import gait_pose
from ipf_jax.geometry.world import up_rotation
from ipf_jax.tracking.shape_fit import lowest_heights

_spec = importlib.util.spec_from_file_location(
    "foot_stance", Path(__file__).parents[1] / "benchmarks" / "foot_stance.py")
foot_stance = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(foot_stance)


def _write(path, shape, U, poses):
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["frame", "time_s"] + [f"{j}_{a}" for j in POINT_NAMES for a in "xyz"])
        for f, q in enumerate(poses):
            w.writerow([f, f / 20] + [f"{v:.6f}" for v in forward_kinematics(q, shape.values, U, xp=np)
                                      .points.ravel()])


def test_a_foot_on_tiptoe_and_a_level_one(tmp_path):
    """Truth: standing, both feet level, two frames. Tracked: the same with the left ankle turned
    10 deg toes-down and the body 20 mm higher: the left foot's heel 33.4 mm over its level height
    (192.5 mm heel-to-toe x sin 10 deg), the right foot level, 20 mm high; its lowest point is
    its poses' (poses.csv), and none without that file."""
    shape, U = default_shape(1.75), up_rotation("+z")
    level = gait_pose(5, 5, 5, 5)
    tiptoe = level.copy()
    tiptoe[DOF_INDEX["left_ankle_dorsiflexion"]] = np.deg2rad(-10)
    tiptoe[DOF_INDEX["root_tz"]] += 0.02
    set_dir = tmp_path / "data" / "stand"
    set_dir.mkdir(parents=True)
    _write(set_dir / "ground_truth.csv", shape, U, [level, level])
    run = tmp_path / "run"
    run.mkdir()
    _write(run / "joints.csv", shape, U, [tiptoe, tiptoe])
    (run / "run.json").write_text(json.dumps({"dataset": str(set_dir), "up_axis": "+z",
                                              "shape": shape.to_json()}))
    left, right = foot_stance.side_rows(run / "run.json", tmp_path / "data")
    assert left["lowest_mm"] is None and right["lowest_mm"] is None  # no poses.csv
    write_rows(run / "poses.csv", POSE_COLUMNS, [0, 1], [0.0, 0.05], [tiptoe, tiptoe])
    low = 1000 * lowest_heights(tiptoe[None], shape.values[None], U)[0]
    flat = 1000 * lowest_heights(level[None], shape.values[None], U)[0]
    assert low < flat + 20 - 5  # the toes went down more than the body went up
    left, right = foot_stance.side_rows(run / "run.json", tmp_path / "data")
    assert left["lowest_mm"] == right["lowest_mm"] == pytest.approx(low, abs=0.1)
    assert left["flat_frames"] == right["flat_frames"] == 2
    assert left["pitch_deg"] == pytest.approx(10, abs=0.1)
    assert left["heel_up_mm"] == pytest.approx(192.5 * np.sin(np.deg2rad(10)), abs=0.2)
    assert right["pitch_deg"] == pytest.approx(0, abs=0.1)
    assert right["heel_up_mm"] == pytest.approx(0, abs=0.2)
    assert right["ankle_up_mm"] == pytest.approx(20, abs=0.1)
    assert foot_stance.side_rows(run / "run.json", tmp_path / "elsewhere") == []  # no ground truth
