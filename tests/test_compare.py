"""``ipf-jax compare``: the filters side by side at one budget, from one initial pose.

The tracking tests are SYNTHETIC (a walk rendered with the tracker's own model through 3 virtual
cameras at 160 x 120, the same scene size as tests/test_filters.py, so no new compiles). The
bodytrack tests read the real PARSEC data (skipped outside CI when absent).
"""
from __future__ import annotations

import csv
import json

import numpy as np
import pytest

from ipf_jax.analysis.compare import (
    Reference,
    StepLog,
    compare,
    fastest,
    load_peer,
    load_truth,
    parse_filters,
)
from ipf_jax.body.model import LIMB_JOINTS, POINT_NAMES
from ipf_jax.body.shape import default_shape
from ipf_jax.cli import main
from ipf_jax.data.dataset import MemoryDataset, open_dataset
from ipf_jax.data.runfiles import POSE_COLUMNS, read_joints_csv
from ipf_jax.errors import IPFError
from ipf_jax.tracking.tracker import Tracker, TrackSettings
from ipf_jax.viz import synthetic as syn
from ipf_jax.viz.synthetic import write_dataset
from ipf_jax.viz.synthetic import write_truth as _write_truth

FPS = 20.0
HEIGHT = 1.72
PEER = "bodytrack_poses_sequenceB_2_4cams_2frames_4000p_5layers_serial.txt"


@pytest.fixture(scope="module")
def walk():
    """SYNTHETIC: 3 frames of a procedural walk, masks in 3 cameras, true joints."""
    shape = default_shape(HEIGHT)
    cams = syn.ring_cameras(3, width=160, height=120, focal_px=300.0)
    q = syn.procedural_walk(3, FPS, shape=shape)
    return {"q": q, "cams": cams, "masks": syn.render_masks(q, shape, cams),
            "joints": syn.joints_of(q, shape)}


def _rows(path):
    with open(path) as fh:
        return list(csv.DictReader(fh))


def test_compare_tracks_every_filter_from_one_pose_at_one_budget(walk, tmp_path):
    ds = MemoryDataset(walk["cams"], walk["masks"], fps=FPS, up_axis="+z")
    truth = Reference("truth", np.arange(3), walk["joints"], POINT_NAMES, "synthetic")
    settings = TrackSettings(init_pose=walk["q"][0], height_m=HEIGHT, chunk=256,
                             filter_options={"noise_scale": 0.5, "layers": 4})
    res = compare(ds, tmp_path, "ipf,apf,sir", 300, settings=settings, references=[truth],
                  peer_seconds=0.41, progress=False)
    table = _rows(tmp_path / "compare.csv")
    assert [r["filter"] for r in table] == ["ipf", "apf", "sir", "initial pose (held)", "bodytrack (peer)"]
    expected = {"ipf": 243, "apf": 300, "sir": 300}  # apf: 75 particles x the 4 layers asked for
    first_poses = []
    for row in table[:3]:
        name = row["filter"]
        run = json.loads((tmp_path / name / "run.json").read_text())
        assert int(row["evaluations_per_frame"]) == run["evaluations_per_frame"] == expected[name]
        assert float(row["measured_evaluations_per_frame"]) == expected[name]  # counted on the scorer
        assert run["filter_params"]["noise_scale"] == 0.5
        assert int(row["frames"]) == 3
        assert [r["status"] for r in run["per_frame"]] == ["init"] + ["tracked"] * 3
        assert 0 < float(row["truth_mm_best"]) < 150 and 0 < float(row["truth_mm_mean"]) < 150
        poses = np.genfromtxt(tmp_path / name / "poses.csv", delimiter=",", skip_header=1)
        first_poses.append(poses[0, 2:])
        # the table's "best" distance is the distance of what joints.csv holds
        ours = read_joints_csv(tmp_path / name / "joints.csv").points[1:]  # (3, J, 3) after the init row
        limb = [POINT_NAMES.index(j) for j in LIMB_JOINTS]
        d = 1000 * np.linalg.norm(ours[:, limb] - walk["joints"][:, limb], axis=-1).mean()
        assert float(row["truth_mm_best"]) == pytest.approx(d, abs=0.01)  # joints.csv has 6 decimals
        means = read_joints_csv(tmp_path / name / "joints_mean.csv")
        assert list(means.frame) == [0, 1, 2]
        d = 1000 * np.linalg.norm(means.points[:, limb] - walk["joints"][:, limb], axis=-1).mean()
        assert float(row["truth_mm_mean"]) == pytest.approx(d, abs=0.01)
    assert np.allclose(first_poses[0], first_poses[1]) and np.allclose(first_poses[0], first_poses[2])
    held = 1000 * np.linalg.norm(walk["joints"][:, limb] - walk["joints"][0, limb], axis=-1).mean()
    assert float(table[3]["truth_mm_best"]) == pytest.approx(held, abs=0.01)  # the walk moves on
    assert table[4]["s_per_frame"] == "0.41"
    frames = _rows(tmp_path / "compare_frames.csv")
    assert [(r["filter"], r["frame"]) for r in frames[:3]] == [("ipf", "0"), ("ipf", "1"), ("ipf", "2")]
    assert len(frames) == 12
    md = (tmp_path / "compare.md").read_text()
    assert "| ipf | 243 |" in md and "to truth, mean (mm)" in md
    assert (tmp_path / "compare.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert res.doc["initial_pose"] == "given" and res.doc["budget"] == 300


def test_automatic_initialisation_runs_once_and_seeds_every_filter(walk, tmp_path, monkeypatch):
    ds = MemoryDataset(walk["cams"], walk["masks"][:2], fps=FPS, up_axis="+z")
    searched = []
    original = Tracker.initialise

    def search(self, frame, obs, small, height, log=None):  # stands in for the automatic search
        if self.settings.init_pose is not None:
            return original(self, frame, obs, small, height, log)
        searched.append(frame)
        q = np.stack([walk["q"][0], walk["q"][1]])
        return q, np.array([2.0, 5.0]), default_shape(1.70), 1234  # what Tracker.initialise returns

    monkeypatch.setattr(Tracker, "initialise", search)
    res = compare(ds, tmp_path, ["sir", "apf"], 200, progress=False,
                  settings=TrackSettings(chunk=256, loss_test=False))  # no recovery on frame 1
    assert searched == [0]  # once, on the first frame, for every filter
    assert res.doc["initial_pose"] == "automatic, run once" and res.doc["init_evaluations"] == 1234
    for n in ("sir", "apf"):
        run = json.loads((tmp_path / n / "run.json").read_text())
        first = np.genfromtxt(tmp_path / n / "poses.csv", delimiter=",", skip_header=1)[0, 2:]
        assert np.allclose(first, walk["q"][1], atol=1e-6)  # the heaviest search result
        assert run["init_evaluations"] == 1 and run["height_m"] == pytest.approx(1.70)


# -- command line -----------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def on_disk(walk, tmp_path_factory):
    """SYNTHETIC dataset folder (CALIB/cameras.json, FGk/*.png), truth CSV and an initial pose."""
    root = tmp_path_factory.mktemp("compare_cli")
    data = write_dataset(root / "walk", walk["cams"], walk["masks"][:2])
    _write_truth(root / "truth.csv", walk["joints"][:2])
    (root / "init.csv").write_text(",".join(POSE_COLUMNS) + "\n0,0," +
                                   ",".join(f"{v:.6f}" for v in walk["q"][0]) + "\n")
    return root, data


def test_cli_compare_writes_the_table(on_disk, capsys):
    root, data = on_disk
    out = root / "out"
    rc = main(["compare", str(data), "--out", str(out), "--filter", "sir,ipf", "--budget", "200",
               "--truth", str(root / "truth.csv"), "--init-pose", str(root / "init.csv"),
               "--height", str(HEIGHT), "--fps", str(FPS), "--chunk", "256", "--quiet"])
    assert rc == 0
    text = capsys.readouterr().out
    assert "| sir | 200 |" in text and "| ipf | 162 |" in text and "wrote compare.csv" in text
    assert [r["filter"] for r in _rows(out / "compare.csv")] == ["sir", "ipf", "initial pose (held)"]
    assert (out / "sir" / "joints.csv").exists() and (out / "ipf" / "run.json").exists()


@pytest.mark.parametrize("extra, problem", [
    (["--filters", "ipf,kalman"], "unknown filter 'kalman'"),
    (["--filters", "sir,sir"], "listed twice"),
    (["--filters", "ipf", "--budget", "50"], "cannot hold one grid of I = 81"),
    (["--filters", "ipf,sir", "--layers", "3"], "layers apply to none of ipf, sir"),
    (["--filters", "apf", "--particles", "300"], "cannot weigh 300 particles"),
    (["--truth", "no_such_truth.csv"], "file not found"),
    (["--peer", "init.csv"], "no BodyShapeParameters.txt"),
    (["--frames", "50:60"], "selects none of the frames"),
    (["--repeat", "0"], "--repeat must be >= 1"),
])
def test_cli_user_mistakes_are_one_line_errors(on_disk, capsys, monkeypatch, extra, problem):
    root, data = on_disk
    monkeypatch.chdir(root)
    args = ["compare", str(data), "--out", str(root / "bad"), "--budget", "200", "--quiet"]
    assert main(args + extra) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: ") and problem in err[0]
    assert not (root / "bad" / "compare.csv").exists()


def test_cli_needs_a_budget(on_disk, capsys):
    with pytest.raises(SystemExit) as e:
        main(["compare", str(on_disk[1]), "--out", "x"])
    assert e.value.code == 2 and "--budget" in capsys.readouterr().err


def test_repeated_steps_keep_the_last_result_and_the_fastest_times():
    a = StepLog("first", 9.0, 4.0, 8.0, 300)  # a step that paid a compilation
    b = StepLog("second", 2.0, 5.0, 1.5, 300)
    assert fastest([a, b]) == StepLog("second", 2.0, 4.0, 1.5, 300)


def test_parse_filters():
    assert parse_filters(" ipf, apf ,sir") == ["ipf", "apf", "sir"]
    for bad in ("", ",", "ipf,pf"):
        with pytest.raises(IPFError):
            parse_filters(bad)


def test_truth_needs_limb_joints(tmp_path):
    (tmp_path / "t.csv").write_text("frame,time_s,foo_x,foo_y,foo_z\n0,0,1,2,3\n")
    with pytest.raises(IPFError, match="no limb joint columns"):
        load_truth(tmp_path / "t.csv")


# -- the bodytrack peer (real data) ---------------------------------------------------------------
def test_peer_poses_become_joints_on_the_dataset_frames(bodytrack_dir, tmp_path):
    ds = open_dataset(bodytrack_dir)
    ref = load_peer(bodytrack_dir.parent / PEER, ds)
    assert ref.label == "peer" and list(ref.frames) == [0, 1]
    assert ref.points.shape[:2] == (2, len(ref.names)) and set(LIMB_JOINTS) <= set(ref.names)
    # the subject hardly moves between bodytrack's two estimates (a few cm at most)
    limb = [ref.names.index(j) for j in LIMB_JOINTS]
    assert np.linalg.norm(ref.points[1, limb] - ref.points[0, limb], axis=-1).mean() < 0.05
    lines = (bodytrack_dir.parent / PEER).read_text().splitlines()
    (tmp_path / "three.txt").write_text("\n".join(lines + lines[:1]) + "\n")
    with pytest.raises(IPFError, match="3 poses but the dataset has only 2 frames"):
        load_peer(tmp_path / "three.txt", ds)


@pytest.mark.slow
def test_sequence_b2_at_bodytracks_budget(bodytrack_dir, tmp_path):
    """Real data: the issue's comparison (4 cameras, 20,000 evaluations per frame, from InitialPose)."""
    rc = main(["compare", str(bodytrack_dir), "--out", str(tmp_path), "--budget", "20000",
               "--init-pose", str(bodytrack_dir / "InitialPose.txt"),
               "--peer", str(bodytrack_dir.parent / PEER), "--peer-seconds", "0.41", "--quiet"])
    assert rc == 0
    rows = {r["filter"]: r for r in _rows(tmp_path / "compare.csv")}
    assert {rows[n]["evaluations_per_frame"] for n in ("ipf", "apf", "sir")} == {"19926", "20000"}
    for n in ("ipf", "apf", "sir"):
        assert float(rows[n]["measured_evaluations_per_frame"]) == float(rows[n]["evaluations_per_frame"])
        assert int(rows[n]["frames"]) == 2
        assert 0 < float(rows[n]["peer_mm_best"]) < 300  # same person, same place, two models
