"""Single-camera helpers: level-camera placement of the person and of the camera, and left/right
leg swap detection and correction, on self-rendered scenes with known answers."""
from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from ipf_jax.analysis import singlecam as sc
from ipf_jax.body.model import DOF_INDEX, POINT_INDEX
from ipf_jax.body.shape import default_shape
from ipf_jax.cli import main
from ipf_jax.data.rundir import joints_from_poses, read_run, write_run_dir
from ipf_jax.errors import IPFError, IPFWarning
from ipf_jax.geometry import placement as pl
from ipf_jax.geometry.posing import gait_pose, place_on_floor
from ipf_jax.geometry.world import up_rotation
from ipf_jax.viz.synthetic import (
    joints_of,
    look_at_camera,
    procedural_walk,
    render_masks,
)

UP = np.array([0.0, 0.0, 1.0])
SHAPE = default_shape(1.70)
CAM_HEIGHT = 1.2


def level_camera(height=CAM_HEIGHT):
    """A level camera 6 m from the origin, looking along +y (the paper's side view)."""
    return look_at_camera((0.0, -6.0, height), (0.0, 0.0, height), width=320, height=240,
                          focal_px=300.0, name="side")


def standing_at(x: float, y: float) -> np.ndarray:
    q = gait_pose(5, 5, 5, 5, heading=0.0)
    q[:2] = x, y
    return place_on_floor(q, SHAPE.values, up_rotation("+z"))


@pytest.fixture(scope="module")
def walk_masks():
    q = procedural_walk(12, 20.0, shape=SHAPE, start=(-0.8, 0.5))
    return q, render_masks(q, SHAPE, [level_camera()])[:, 0]


def test_person_extent_joins_a_silhouette_cut_in_two():
    mask = np.zeros((100, 60), bool)
    mask[10:50, 20:40] = True  # torso
    mask[55:90, 22:30] = True  # legs, separated by a gap (clothes like the background)
    mask[5:8, 50:58] = True  # a speck elsewhere: not the person
    (uf, vf), (uh, vh) = pl.person_extent(mask)
    assert (vf, vh) == (89.5, 9.5)
    assert uf == uh == pytest.approx((800 * 29.5 + 280 * 25.5) / 1080)  # area-weighted centre
    assert pl.person_extent(np.zeros((10, 10), bool)) is None


@pytest.mark.parametrize("x,y", [(0.0, 0.0), (1.2, 1.5), (-1.0, -1.5)])
def test_floor_point_of_a_standing_person(x, y):
    cam = level_camera()
    mask = render_masks(standing_at(x, y)[None], SHAPE, [cam])[0, 0]
    by_height = pl.floor_point_single(mask, cam, UP, SHAPE.height_m)
    by_feet = pl.floor_point_single(mask, cam, UP, None)
    # across the view: the silhouette's centre column is not quite the sacrum's; in depth (what
    # one camera measures worst) a pixel at 6 m is 2 cm across and the model's soles and crown are
    # a few cm from the silhouette's extremes
    for p in (by_height, by_feet):
        assert p[2] == 0.0
        assert abs(p[0] - x) < 0.08 and abs(p[1] - y) < 0.25, p


def test_floor_point_by_height_ignores_a_wrong_camera_height():
    cam = level_camera()
    mask = render_masks(standing_at(0.5, 0.0)[None], SHAPE, [cam])[0, 0]
    wrong = pl.camera_at_height(cam, UP, 1.7)  # the nominal calibration is 50 cm too high
    p = pl.floor_point_single(mask, wrong, UP, SHAPE.height_m)
    assert abs(p[1]) < 0.25 and abs(p[0] - 0.5) < 0.08
    assert pl.floor_point_single(np.zeros_like(mask), cam, UP, 1.7) is None


def test_camera_height_from_a_walking_person(walk_masks):
    _, masks = walk_masks
    nominal = pl.camera_at_height(level_camera(), UP, 1.7)
    h, per_frame = pl.camera_height_from_person(nominal, list(masks), UP, SHAPE.height_m)
    assert per_frame.shape == (len(masks),) and np.all(np.isfinite(per_frame))
    assert abs(h - CAM_HEIGHT) < 0.05, h  # silhouette top/bottom vs standing height: a few cm
    with pytest.raises(IPFError, match="no person silhouette"):
        pl.camera_height_from_person(nominal, [np.zeros_like(masks[0])], UP, 1.7)


SPOTS = [(0.0, 0.0), (0.5, 0.5), (-1.0, 1.0), (1.0, -0.5), (-0.5, -1.0), (0.3, 1.5)]


def sharp_camera(centre=(0.0, -6.0, CAM_HEIGHT), target=(0.0, 0.0, CAM_HEIGHT)):
    """640 x 480, f = 600 px: a pixel is 1 cm at 6 m."""
    return look_at_camera(centre, target, width=640, height=480, focal_px=600.0, name="side")


@pytest.fixture(scope="module")
def standing_masks():
    """The person standing at :data:`SPOTS`, seen by :func:`sharp_camera`."""
    q = np.stack([standing_at(x, y) for x, y in SPOTS])
    return q, render_masks(q, SHAPE, [sharp_camera()])[:, 0]


def test_height_from_one_calibrated_view(standing_masks):
    """Self-rendered (the tracker's own capsule body): a person's height from one calibrated
    view, level or from above; the feet must be on the floor (a floating foot reads as a taller
    person further away)."""
    q, masks = standing_masks
    h, per_frame = pl.height_from_view(sharp_camera(), list(masks), UP)
    assert per_frame.shape == (len(masks),) and np.all(np.isfinite(per_frame))
    assert abs(h - SHAPE.height_m) < 0.02, h  # a pixel is 1 cm
    high = sharp_camera((0.0, -4.0, 2.6), (0.0, 0.0, 0.9))
    h_high, _ = pl.height_from_view(high, list(render_masks(q, SHAPE, [high])[:, 0]), UP)
    assert abs(h_high - SHAPE.height_m) < 0.035, h_high  # from above: the silhouette's ends are
    # not the crown and the soles' lowest points (measured 2.8 cm over)


def test_height_from_view_needs_a_camera_on_its_feet_and_whole_people(standing_masks):
    _, masks = standing_masks
    cam = sharp_camera()
    # upside down (image rows and columns flipped, as bodytrack's cameras are): the same height
    flip = np.diag([-1.0, -1.0, 1.0])
    K = cam.K.copy()
    K[0, 2], K[1, 2] = cam.width - 1 - cam.K[0, 2], cam.height - 1 - cam.K[1, 2]
    flipped = dataclasses.replace(cam, R=flip @ cam.R, T=flip @ cam.T, K=K)
    h, _ = pl.height_from_view(cam, list(masks), UP)
    h_flip, _ = pl.height_from_view(flipped, [m[::-1, ::-1] for m in masks], UP)
    assert h_flip == pytest.approx(h, abs=1e-6)
    # rolled on its side: no answer
    roll = np.array([[0.0, 1, 0], [-1, 0, 0], [0, 0, 1]])
    side = dataclasses.replace(cam, R=roll @ cam.R, T=roll @ cam.T)
    assert np.isnan(pl.height_from_view(side, list(masks), UP)[0])
    # a person cut by the image's border is skipped; fewer than HEIGHT_MIN_FRAMES: no answer
    cut = [m.copy() for m in masks]
    for m in cut:
        m[-1, np.flatnonzero(m.any(0))[0]] = True
    assert np.all(np.isnan(pl.height_from_view(cam, cut, UP)[1]))
    assert np.isnan(pl.height_from_view(cam, list(masks[: pl.HEIGHT_MIN_FRAMES - 1]), UP)[0])
    # the camera below the floor (a wrong up axis): no answer
    assert np.isnan(pl.height_from_view(cam, list(masks), -UP)[0])


def test_one_camera_run_measures_the_height(standing_masks, tmp_path):
    from ipf_jax.data.dataset import open_dataset
    from ipf_jax.tracking.settings import TrackSettings
    from ipf_jax.tracking.tracker import Tracker
    from ipf_jax.viz.synthetic import write_dataset

    _, masks = standing_masks
    data = open_dataset(write_dataset(tmp_path / "data", [sharp_camera()], masks[:, None]))
    assert Tracker(data, TrackSettings(up_axis="+z")).height_measured is None  # off by default
    tracker = Tracker(data, TrackSettings(up_axis="+z", height_from_view=True))
    got = tracker.height_measured
    assert got["not_used"] is None and abs(got["height_m"] - SHAPE.height_m) < 0.02
    assert tracker.settings.height_m == got["height_m"] and got["usable_frames"] == len(masks)
    with pytest.warns(IPFWarning, match="not measured .a height is given"):
        assert Tracker(data, TrackSettings(up_axis="+z", height_m=1.8,
                                           height_from_view=True)).height_measured is None
    two = open_dataset(write_dataset(tmp_path / "two", [sharp_camera()] * 2, np.stack([masks] * 2, 1)))
    with pytest.warns(IPFWarning, match="with one camera, not 2"):
        assert Tracker(two, TrackSettings(up_axis="+z", height_from_view=True)).height_measured is None
    # someone who does not stay upright (every other frame only the legs: a person crouching
    # behind something) is searched instead
    low = masks.copy()
    for t in range(0, len(low), 2):
        rows = np.flatnonzero(masks[t].any(1))
        low[t][: rows[len(rows) // 2]] = False
    crouch = open_dataset(write_dataset(tmp_path / "crouch", [sharp_camera()], low[:, None]))
    with pytest.warns(IPFWarning, match="does not stay upright"):
        got = Tracker(crouch, TrackSettings(up_axis="+z", height_from_view=True)).height_measured
    assert "not stay upright" in got["not_used"] and got["spread_m"] > 0.15
    assert got["height_m"] is not None


def test_camera_at_height_keeps_orientation_and_intrinsics():
    cam = level_camera()
    moved = pl.camera_at_height(cam, UP, 2.0)
    np.testing.assert_allclose(moved.centre, [0.0, -6.0, 2.0], atol=1e-12)
    np.testing.assert_array_equal(moved.R, cam.R)
    np.testing.assert_array_equal(moved.K, cam.K)


# --- leg swaps ----------------------------------------------------------------------------------

FPS = 30.0


@pytest.fixture(scope="module")
def walk():
    q = procedural_walk(75, FPS, shape=SHAPE, heading_deg=180.0, start=(2.0, 0.0))
    return q, joints_of(q, SHAPE)


def exchange(q: np.ndarray, rows) -> np.ndarray:
    parity = np.zeros(len(q), bool)
    parity[list(rows)] = True
    return sc.swap_leg_dofs(q, parity)


def crossings(joints) -> np.ndarray:
    """Rows just after the two ankles pass each other along the walk."""
    legs = sc.sagittal_legs(joints, UP)
    d = legs[:, 0, 1, 0] - legs[:, 1, 1, 0]  # left minus right ankle, forward
    return np.nonzero(np.sign(d[1:]) != np.sign(d[:-1]))[0] + 1


def test_clean_and_jittery_walks_have_no_swaps(walk):
    q, joints = walk
    assert len(sc.detect_leg_swaps(joints, UP).swaps) == 0
    rng = np.random.default_rng(0)
    noisy = joints + rng.normal(0, 0.01, joints.shape)  # 1 cm tracker jitter per coordinate
    found = sc.detect_leg_swaps(noisy, UP)
    assert len(found.swaps) == 0 and not found.parity.any()


def test_label_jumps_are_found_and_undone(walk):
    q, joints = walk
    bad = exchange(q, range(20, 41))  # e.g. a re-initialisation that picked the other leg
    found = sc.detect_leg_swaps(joints_of(bad, SHAPE), UP)
    assert found.swaps.tolist() == [20, 41]
    assert found.parity.sum() == 21
    np.testing.assert_allclose(sc.swap_leg_dofs(bad, found.parity), q)


def test_bounce_at_a_crossing_is_found(walk):
    q, joints = walk
    c = int(crossings(joints)[1])
    bad = exchange(q, range(c, len(q)))  # the model's legs meet and go back instead of passing
    bad_joints = joints_of(bad, SHAPE)
    rng = np.random.default_rng(1)
    found = sc.detect_leg_swaps(bad_joints + rng.normal(0, 0.005, joints.shape), UP)
    assert found.swaps.tolist() == [c]
    fixed = joints_from_poses(sc.swap_leg_dofs(bad, found.parity), SHAPE, "+z")
    np.testing.assert_allclose(fixed, joints, atol=1e-9)


def test_smooth_bounces_break_the_alternation_of_steps(walk):
    q, joints = walk
    cs = crossings(joints)
    bad = exchange(q, list(range(cs[0], cs[1])) + list(range(cs[2], len(q))))
    bad_joints = joints_of(bad, SHAPE)
    # continuity alone (jumps) off: only the same-sided steps reveal the swaps
    found = sc.detect_leg_swaps(bad_joints, UP, min_gain_m=10.0)
    assert len(found.swaps) == 3
    for got, want in zip(found.swaps, cs[:3]):
        assert want - 1 <= got <= want  # the meeting row itself may go either way
    fixed = joints_from_poses(sc.swap_leg_dofs(bad, found.parity), SHAPE, "+z")
    err = np.linalg.norm(fixed - joints, axis=-1).max(axis=1)
    assert np.all((err < 1e-9) | np.isin(np.arange(len(q)), cs - 1)), np.nonzero(err > 1e-9)
    assert len(sc.detect_leg_swaps(bad_joints, UP, min_gain_m=10.0, meeting_m=None).swaps) == 0


def test_missing_rows_are_skipped(walk):
    q, joints = walk
    bad = joints_of(exchange(q, range(30, 75)), SHAPE)
    bad[28:30] = np.nan  # the swap happens across a gap
    found = sc.detect_leg_swaps(bad, UP, np.arange(len(bad)))
    assert found.swaps.tolist() == [30]
    assert found.parity[28:30].tolist() == [False, False] and np.isnan(found.gain_m[28])


def test_swapping_points_keeps_legs_on_their_hips(walk):
    q, joints = walk
    parity = np.zeros(len(q), bool)
    parity[5:9] = True
    swapped = sc.swap_leg_points(joints, parity)
    hip = POINT_INDEX["left_hip"]
    # the leg below the left hip now has the right leg's shape relative to its hip
    rel_new = swapped[5:9, POINT_INDEX["left_ankle"]] - swapped[5:9, hip]
    rel_old = joints[5:9, POINT_INDEX["right_ankle"]] - joints[5:9, POINT_INDEX["right_hip"]]
    np.testing.assert_allclose(rel_new, rel_old, atol=1e-12)
    np.testing.assert_array_equal(swapped[:5], joints[:5])
    np.testing.assert_array_equal(sc.swap_leg_points(swapped, parity), joints)


def test_fix_single_writes_a_corrected_run(walk, tmp_path, capsys):
    q, _ = walk
    bad = exchange(q, range(40, 75))
    bad[10] = np.nan  # a missing frame stays missing
    run_dir = write_run_dir(tmp_path / "run", bad, shape=SHAPE, fps=FPS, meta={"dataset": "x"})
    assert main(["fix-single", str(run_dir), "--out", str(tmp_path / "fixed"),
                    "--keep-depth"]) == 0
    assert "1 leg swap(s) at frame(s) [40] (35 frames exchanged)" in capsys.readouterr().out
    fixed = read_run(tmp_path / "fixed")
    expect = q.copy()
    expect[10] = np.nan
    np.testing.assert_allclose(fixed.poses, expect, atol=2e-6)  # CSV: 6 decimals
    assert np.isnan(fixed.joints[10]).all()
    meta = json.loads((tmp_path / "fixed" / "run.json").read_text())
    assert meta["single_camera"]["leg_swaps"]["swap_frames"] == [40] and meta["dataset"] == "x"
    assert meta["single_camera"]["steady_depth"] is None
    assert fixed.poses[50, DOF_INDEX["left_hip_flexion"]] == pytest.approx(
        q[50, DOF_INDEX["left_hip_flexion"]], abs=2e-6)


def test_steady_depth_removes_jitter_along_the_view(walk, tmp_path):
    q, joints = walk
    cam = look_at_camera((0.0, -6.0, 1.2), (0.0, 0.0, 1.2), width=320, height=240, focal_px=300.0)
    rng = np.random.default_rng(2)
    jitter = np.zeros((len(q), 3))
    jitter[:, 1] = rng.normal(0, 0.1, len(q))  # 10 cm of depth noise (world y = the view)
    shaky = q.copy()
    shaky[:, :3] += jitter
    shifts, fit = pl.steady_depth(joints_of(shaky, SHAPE), cam, UP)
    steadied = joints_of(shaky, SHAPE) + shifts[:, None]
    depth = steadied[:, POINT_INDEX["sacrum"], 1] + 6.0
    resid = depth - (fit[0] + fit[1] * (np.arange(len(q)) - (len(q) - 1) / 2))
    assert np.abs(resid).max() < 1e-9  # on the fitted line exactly
    assert abs(fit[0] - 6.0) < 0.05 and abs(fit[1]) < 0.005
    from ipf_jax.geometry.host import project_points
    before = project_points(cam, joints_of(shaky, SHAPE)[:, 0])[0]
    after = project_points(cam, steadied[:, 0])[0]
    np.testing.assert_allclose(after, before, atol=1e-6)  # the sacrum's image is kept
    # through the command, with the camera from a dataset.json
    run_dir = write_run_dir(tmp_path / "run", shaky, shape=SHAPE, fps=FPS)
    rec = sc.fix_single_camera(run_dir, tmp_path / "out", legs=False, camera=cam)
    assert rec["leg_swaps"] is None and rec["steady_depth"]["depth_m"] == pytest.approx(6.0, abs=0.05)
    fixed = read_run(tmp_path / "out")
    np.testing.assert_allclose(joints_from_poses(fixed.poses, SHAPE, "+z"), fixed.joints, atol=1e-5)


def test_fix_single_refuses_to_overwrite_the_run(walk, tmp_path, capsys):
    run_dir = write_run_dir(tmp_path / "run", walk[0][:10], shape=SHAPE, fps=FPS)
    assert main(["fix-single", str(run_dir), "--out", str(run_dir), "--keep-depth"]) == 2
    assert "write the corrected run to another folder" in capsys.readouterr().err
    assert main(["fix-single", str(run_dir), "--out", str(tmp_path / "o")]) == 2
    assert "give --dataset (or --keep-depth)" in capsys.readouterr().err
    other = write_run_dir(tmp_path / "other", walk[0][10:20], shape=SHAPE, fps=FPS)  # another run
    before = {p.name: p.read_bytes() for p in other.iterdir()}
    assert main(["fix-single", str(run_dir), "--out", str(other), "--keep-depth"]) == 2
    assert "other: holds a tracked run (run.json)" in capsys.readouterr().err
    assert {p.name: p.read_bytes() for p in other.iterdir()} == before
    fixed = tmp_path / "fixed"  # an earlier fix-single output is replaced
    assert main(["fix-single", str(run_dir), "--out", str(fixed), "--keep-depth"]) == 0
    assert main(["fix-single", str(run_dir), "--out", str(fixed), "--keep-depth"]) == 0
    for flag in ("--min-gain", "--meeting"):  # inf silently turned the correction off
        assert main(["fix-single", str(run_dir), "--out", str(fixed), "--keep-depth", flag, "inf"]) == 2
        assert f"{flag} must be" in capsys.readouterr().err


def test_fix_single_takes_the_camera_from_the_dataset(walk_masks, tmp_path, capsys):
    from ipf_jax.viz.synthetic import write_dataset

    q, masks = walk_masks
    data = write_dataset(tmp_path / "data", [level_camera()], masks[:, None])
    run_dir = write_run_dir(tmp_path / "run", q, shape=SHAPE, fps=20.0, meta={"dataset": str(data)})
    assert main(["fix-single", str(run_dir), "--out", str(tmp_path / "o"), "--camera",
                    "side"]) == 0
    out = capsys.readouterr().out
    assert "0 leg swap(s)" in out and "depth steadied to" in out and "from side" in out
    assert main(["fix-single", str(run_dir), "--out", str(tmp_path / "o"), "--camera",
                    "3"]) == 2
    assert "--camera: no camera '3' (cameras: side, or 1..1)" in capsys.readouterr().err


def test_fix_single_refuses_another_camera_than_the_runs(walk_masks, tmp_path, capsys):
    """The depth is steadied along the run's own camera: a run of several cameras, a camera of
    another name, or one of that name calibrated elsewhere is one error line."""
    from ipf_jax.viz.synthetic import write_dataset

    q, masks = walk_masks
    data = write_dataset(tmp_path / "data", [level_camera()], masks[:, None])
    other = dataclasses.replace(level_camera(), T=level_camera().T + 0.5)  # same name, elsewhere
    elsewhere = write_dataset(tmp_path / "elsewhere", [other], masks[:, None])
    argv = lambda run, *extra: ["fix-single", str(run), "--out", str(tmp_path / "o"), *extra]  # noqa: E731
    two = write_run_dir(tmp_path / "two", q, shape=SHAPE, fps=20.0,
                        meta={"dataset": str(data), "cameras": ["side", "front"]})
    assert main(argv(two)) == 2
    assert "corrects single-camera runs; this run used 2 cameras (side, front)" in capsys.readouterr().err
    run = write_run_dir(tmp_path / "run", q, shape=SHAPE, fps=20.0,
                        meta={"dataset": str(data), "cameras": ["side"]})
    assert main(argv(run, "--dataset", str(elsewhere))) == 2
    assert "camera side of this dataset is not the one the run was tracked with" in capsys.readouterr().err
    named = write_run_dir(tmp_path / "named", q, shape=SHAPE, fps=20.0,
                          meta={"dataset": str(data), "cameras": ["front"]})
    assert main(argv(named)) == 2
    assert "the run was tracked with camera front, not side" in capsys.readouterr().err
    assert main(argv(run)) == 0  # its own camera
