"""Inputs that used to give a misleading message or a silently wrong answer (an audit of the
commands with bad input, 2026-12-06): each is now one clear line or a warning."""
from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from ipf_jax.analysis.compare import Reference, compare
from ipf_jax.analysis.gait.vertical import warn_if_contradicted
from ipf_jax.body import default_shape
from ipf_jax.cli import main
from ipf_jax.data.dataset import MemoryDataset
from ipf_jax.errors import IPFError, IPFWarning
from ipf_jax.tracking.tracker import TrackSettings
from ipf_jax.viz import synthetic as syn


def _one_error(argv, capsys) -> str:
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: ") and "\n" not in err
    return err


def test_a_folder_for_a_file_and_a_file_for_a_folder(tmp_path, capsys):
    (tmp_path / "joints.csv").write_text("frame,time_s\n0,0.0\n")
    assert "is a folder: give a joints CSV" in _one_error(["gait", str(tmp_path), "--out",
                                                            str(tmp_path / "g")], capsys)
    assert "is a file: give the run's folder" in _one_error(
        ["export", str(tmp_path / "joints.csv"), "--format", "trc", "--out", str(tmp_path / "x.trc")], capsys)


def test_an_up_axis_the_body_contradicts_is_a_warning():
    t = np.linspace(0, 1, 20)[:, None]
    walk = np.hstack([t, np.zeros_like(t), np.zeros_like(t)])  # walking along x, z up
    points = {"sacrum": walk + [0, 0, 0.95], "left_ankle": walk + [0, 0.1, 0.08],
              "right_ankle": walk + [0, -0.1, 0.08]}
    with pytest.warns(IPFWarning, match=r"--up \+x, but the pelvis is .* along \+z: is the up axis \+z\?"):
        warn_if_contradicted(points, "+x", "walk.csv")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        warn_if_contradicted(points, "+z", "walk.csv")  # agreed: silent


def test_compare_refuses_a_truth_of_other_frames_before_tracking(tmp_path):
    shape = default_shape(1.75)
    cams = syn.ring_cameras(2, width=80, height=60, focal_px=75)
    q = syn.procedural_walk(3, shape=shape)
    ds = MemoryDataset(cams, syn.render_masks(q, shape, cams), fps=20.0)
    ref = Reference("truth", np.arange(1000, 1003), np.zeros((3, 1, 3)), ("left_knee",), "t.csv")
    said = r"shares no frame number with the frames compared \(0..2; it has 1000..1002\)"
    with pytest.raises(IPFError, match=said):
        compare(ds, tmp_path / "c", "ipf", 81, settings=TrackSettings(), references=[ref], progress=False)
    assert not (tmp_path / "c").exists()  # nothing tracked


def test_a_first_pose_outside_the_limits_is_a_warning():
    """A limits file whose root range excludes where the silhouettes put the person: the floor
    placement wins, and the run says so instead of writing a pose outside the limits silently."""
    from types import SimpleNamespace

    from ipf_jax.body.limits import load_limits
    from ipf_jax.body.model import DOF_INDEX, NUM_DOF
    from ipf_jax.tracking.tracker import Tracker

    limits = load_limits("default")
    lower, upper = limits.lower.copy(), limits.upper.copy()
    lower[DOF_INDEX["root_tz"]], upper[DOF_INDEX["root_tz"]] = 5.0, 6.0
    fake = SimpleNamespace(limits=limits._replace(lower=lower, upper=upper, name="away"))
    pose = np.zeros(NUM_DOF)
    pose[DOF_INDEX["root_tz"]] = 0.9
    said = r"outside the limits \(away\) in root_tz: root_tz 0.900 not in 5.000..6.000"
    with pytest.warns(IPFWarning, match=said):
        Tracker._check_within_limits(fake, pose)
    pose[DOF_INDEX["root_tz"]] = 5.5
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        Tracker._check_within_limits(fake, pose)


def test_calibration_limits_and_dataset_files_that_say_something_else(tmp_path):
    """A misspelt camera key is a warning, R and rvec together an error, a camera matrix whose last
    row is not (0, 0, 1) an error; a boolean in a limits
    range and a dataset.json of another version are errors."""
    import json

    from ipf_jax.body.limits import load_limits
    from ipf_jax.data.calibration import read_json, write_json
    from ipf_jax.data.sources import build_sources

    write_json(syn.ring_cameras(2, width=80, height=60, focal_px=75), tmp_path / "c.json")
    doc = json.loads((tmp_path / "c.json").read_text())
    doc["cameras"][0]["dst"] = doc["cameras"][0].pop("dist")
    (tmp_path / "c.json").write_text(json.dumps(doc))
    with pytest.warns(IPFWarning, match=r"camera 0: unknown key\(s\) dst ignored"):
        read_json(tmp_path / "c.json")
    doc["cameras"][1]["rvec"] = [0.0, 0.0, 0.0]
    (tmp_path / "c.json").write_text(json.dumps(doc))
    with pytest.raises(IPFError, match="camera 1: give R or rvec, not both"), warnings.catch_warnings():
        warnings.simplefilter("ignore", IPFWarning)
        read_json(tmp_path / "c.json")
    del doc["cameras"][1]["rvec"]
    doc["cameras"][1]["K"][2][2] = 2.0  # a homogeneous scale the projection would ignore
    (tmp_path / "c.json").write_text(json.dumps(doc))
    with pytest.raises(IPFError, match=r"camera matrix is not upper-triangular with last row \(0, 0, 1\)"), \
            warnings.catch_warnings():
        warnings.simplefilter("ignore", IPFWarning)
        read_json(tmp_path / "c.json")
    lim = json.loads((Path(__file__).parents[1] / "ipf_jax/body/presets/limits_default.json").read_text())
    lim["dofs"]["left_knee_flexion"] = [0, True]
    (tmp_path / "l.json").write_text(json.dumps(lim))
    with pytest.raises(IPFError, match=r"left_knee_flexion: range values must be numbers"):
        load_limits(tmp_path / "l.json")
    with pytest.raises(IPFError, match=r"'version' 99: this ipf-jax reads dataset.json version 1"):
        build_sources(tmp_path, {"version": 99, "calibration": "c.json", "cameras": []})


def test_bench_quick_says_which_options_it_replaces():
    from types import SimpleNamespace

    from ipf_jax.cli.bench import QUICK_SETS, warn_quick_overrides

    with pytest.warns(IPFWarning, match=r"--cameras ignored \(drop --quick to use them\)"):
        warn_quick_overrides(SimpleNamespace(**{**QUICK_SETS, "cameras": "9"}))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        warn_quick_overrides(SimpleNamespace(**QUICK_SETS))


def test_an_initial_pose_the_limits_clamp_is_a_warning():
    """--init-pose with a knee bent 50 rad is clamped to the limits: said, not silent; a heading
    of 4 rad is wrapped (periodic), which is no clamp."""
    from types import SimpleNamespace

    from ipf_jax.body.limits import load_limits
    from ipf_jax.body.model import DOF_INDEX, NUM_DOF
    from ipf_jax.tracking.tracker import Tracker

    limits = load_limits("default")
    fake = SimpleNamespace(limits=limits)
    pose = np.zeros(NUM_DOF)
    pose[DOF_INDEX["root_yaw"]] = 4.0
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        Tracker._check_within_limits(fake, pose, "the initial pose")
    pose[DOF_INDEX["left_knee_flexion"]] = 50.0
    with pytest.warns(IPFWarning, match=r"the initial pose lies outside the limits \(default\) in "
                                        r"left_knee_flexion: left_knee_flexion 50.000"):
        Tracker._check_within_limits(fake, pose, "the initial pose")


def test_init_dataset_refuses_a_background_of_another_size(tmp_path, capsys):
    """init-dataset used to write a dataset.json whose background only track refused."""
    import cv2

    from ipf_jax.data.calibration import write_json

    (tmp_path / "cam1").mkdir()
    for k in range(3):
        cv2.imwrite(str(tmp_path / "cam1" / f"image{k:04d}.png"), np.full((30, 40, 3), 10 * k, np.uint8))
    cv2.imwrite(str(tmp_path / "bg.png"), np.zeros((15, 20, 3), np.uint8))
    write_json(syn.ring_cameras(1, width=40, height=30, focal_px=40), tmp_path / "c.json")
    err = _one_error(["init-dataset", str(tmp_path / "cam1"), "--calibration", str(tmp_path / "c.json"),
                      "--background", str(tmp_path / "bg.png"), "--out", str(tmp_path / "d")], capsys)
    assert "background is 20x15, the frames of cam1 are 40x30" in err
    assert not (tmp_path / "d" / "dataset.json").exists()
    cv2.imwrite(str(tmp_path / "bg.png"), np.zeros((30, 40, 3), np.uint8))
    assert main(["init-dataset", str(tmp_path / "cam1"), "--calibration", str(tmp_path / "c.json"),
                 "--background", str(tmp_path / "bg.png"), "--out", str(tmp_path / "d")]) == 0



def test_init_dataset_refuses_one_input_for_two_cameras_and_a_background_for_masks(tmp_path, capsys):
    """The same folder twice made a dataset whose two cameras saw one view (tracked silently);
    --background with --masks wrote a dataset.json that track refused."""
    import cv2

    from ipf_jax.data.calibration import write_json

    for name in ("FG1", "FG2"):
        (tmp_path / name).mkdir()
        for k in range(3):
            cv2.imwrite(str(tmp_path / name / f"image{k:04d}.png"), np.zeros((30, 40), np.uint8))
    write_json(syn.ring_cameras(2, width=40, height=30, focal_px=40), tmp_path / "c.json")
    init = ["init-dataset", "--calibration", str(tmp_path / "c.json"), "--masks",
            "--out", str(tmp_path / "d")]
    err = _one_error([*init, str(tmp_path / "FG1"), str(tmp_path / "FG2" / ".." / "FG1")], capsys)
    assert "FG1: given for two cameras" in err
    backgrounds = [str(tmp_path / f"FG{k}" / "image0000.png") for k in (1, 2)]
    err = _one_error([*init, str(tmp_path / "FG1"), str(tmp_path / "FG2"), "--background", *backgrounds],
                     capsys)
    assert "--background applies to camera images or videos: masks need none" in err
    assert not (tmp_path / "d" / "dataset.json").exists()
    assert main([*init, str(tmp_path / "FG1"), str(tmp_path / "FG2")]) == 0


def test_a_camera_list_naming_no_camera_is_refused():
    """render --cameras ',' and fix-single --camera ',' were internal errors (an empty selection)."""
    from ipf_jax.data.dataset import pick_cameras

    cams = syn.ring_cameras(2, width=80, height=60, focal_px=75)
    for text in (",", " ", " , "):
        said = r"--cameras '.*' names no camera \(cameras: Camera1, Camera2, or 1..2\)"
        with pytest.raises(IPFError, match=said):
            pick_cameras(cams, text, "--cameras")
    assert pick_cameras(cams, "2, Camera1", "--cameras") == [1, 0] and pick_cameras(cams, None) == [0, 1]
