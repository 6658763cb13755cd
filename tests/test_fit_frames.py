"""benchmarks/fit_frames.py: the shape fit's frames against a ground truth (here one made from
known poses, so the errors are known)."""
from __future__ import annotations

import csv
import importlib.util
import json
from pathlib import Path

import numpy as np

from ipf_jax.body.model import DOF_INDEX, POINT_INDEX
from ipf_jax.body.shape import default_shape
from ipf_jax.geometry.kinematics import forward_kinematics
from ipf_jax.geometry.posing import gait_pose
from ipf_jax.geometry.world import up_rotation

_spec = importlib.util.spec_from_file_location(
    "fit_frames", Path(__file__).parents[1] / "benchmarks" / "fit_frames.py")
fit_frames = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(fit_frames)


def _legs_swapped(q):
    out = q.copy()
    for d in ("hip_flexion", "hip_abduction", "hip_rotation", "knee_flexion", "ankle_dorsiflexion",
              "ankle_inversion"):
        left, right = DOF_INDEX[f"left_{d}"], DOF_INDEX[f"right_{d}"]
        out[left], out[right] = q[right], q[left]
    return out


def test_a_right_pose_and_one_with_its_legs_swapped(tmp_path):
    shape, U = default_shape(1.75), up_rotation("+z")
    truth = {0: gait_pose(25, 10, -15, 5), 4: gait_pose(-20, 30, 20, 5)}
    names = fit_frames.LIMB_JOINTS
    set_dir = tmp_path / "data" / "walk"
    set_dir.mkdir(parents=True)
    with open(set_dir / "ground_truth.csv", "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["frame", "time_s"] + [f"{j}_{a}" for j in names for a in "xyz"])
        for f, q in truth.items():
            pts = forward_kinematics(q, shape.values, U, xp=np).points
            w.writerow([f, f / 20] + [f"{v:.6f}" for j in names for v in pts[POINT_INDEX[j]]])
    run = tmp_path / "run"
    run.mkdir()
    poses = [{"frame": 0, "weight": 9.0, "pose": truth[0].tolist()},
             {"frame": 4, "weight": 5.0, "pose": _legs_swapped(truth[4]).tolist()}]
    (run / "run.json").write_text(json.dumps({
        "dataset": str(set_dir), "up_axis": "+z", "shape": shape.to_json(),
        "shape_fit": {"frame_poses": poses}}))
    rows = fit_frames.frame_rows(run / "run.json", tmp_path / "data")
    assert [r["frame"] for r in rows] == [0, 4]
    assert rows[0]["mpjpe_mm"] < 0.1 and not rows[0]["legs_swapped"]
    assert rows[1]["mpjpe_mm"] > 20 and rows[1]["legs_swapped"]
    assert rows[1]["worst_joint"].endswith("ankle")
    assert fit_frames.frame_rows(run / "run.json", tmp_path / "elsewhere") == []  # no ground truth
