"""Export of run directories to TRC, C3D, BVH and CSV: round trips through independent readers."""
from __future__ import annotations

import json

import ezc3d
import numpy as np
import pytest

from ipf_jax.analysis.export import (
    bvh_positions,
    export_bvh,
    export_c3d,
    export_csv,
    export_trc,
    file_rotation,
    read_bvh,
    read_run,
    sample_rate,
    to_file_frame,
    write_run_dir,
)
from ipf_jax.analysis.gait.io import load as load_trajectories
from ipf_jax.body import POINT_NAMES, default_shape, load_limits
from ipf_jax.body.model import NUM_DOF
from ipf_jax.cli.export import main
from ipf_jax.errors import IPFError
from ipf_jax.geometry.world import AXES, axis_vector

BVH_TOL_M = 1e-3  # the brief: BVH forward kinematics within 1 mm of joints.csv
CSV_ROUNDING_M = 0.6e-6  # joints.csv and the text exports keep 6 decimals of metres

# Where each of our points sits in the BVH file (docs/export.md), written out independently of
# the writer's generic skeleton builder.
BVH_SITE = {
    "sacrum": "pelvis", "neck": "head", "head": "head.end",
    **{f"{s}_{p}": f"{s}_{j}" for s in ("left", "right") for p, j in (
        ("hip", "thigh"), ("knee", "shank"), ("ankle", "foot"), ("toe", "toe"),
        ("heel", "toe.end"), ("shoulder", "upper_arm"), ("elbow", "forearm"),
        ("wrist", "forearm.end"))},
}


def random_poses(rng: np.random.Generator, T: int, missing=(3, 4)) -> np.ndarray:
    """(T, D) poses uniform over the default limits (plus both corners), NaN rows at ``missing``."""
    limits = load_limits("default")
    lo, hi = limits.lower.copy(), limits.upper.copy()
    lo[:3], hi[:3] = -3.0, 3.0
    q = rng.uniform(lo, hi, size=(T, NUM_DOF))
    q[-2], q[-1] = lo, hi
    q[list(missing)] = np.nan
    return q


@pytest.fixture
def run_dir(tmp_path):
    return write_run_dir(tmp_path / "run", random_poses(np.random.default_rng(0), 24),
                         up_axis="-z", fps=50.0, frames=np.arange(100, 124))


# --------------------------------------------------------------------------------------------------
# Run directory and axes


def test_write_run_dir_reads_back(tmp_path):
    q = random_poses(np.random.default_rng(1), 10, missing=(0, 7))
    shape = default_shape(1.6)
    run = read_run(write_run_dir(tmp_path, q, shape=shape, up_axis="+y", fps=30.0,
                                 meta={"note": "x"}))
    assert run.up_axis == "+y" and run.fps == 30.0 and run.meta["note"] == "x"
    np.testing.assert_allclose(run.shape.values, shape.values)
    np.testing.assert_array_equal(run.frames, np.arange(10))
    np.testing.assert_allclose(run.time_s, np.arange(10) / 30.0, atol=1e-6)
    np.testing.assert_allclose(run.poses, q, atol=CSV_ROUNDING_M, equal_nan=True)
    assert run.joints.shape == (10, 19, 3)
    assert np.isnan(run.joints[[0, 7]]).all() and np.isfinite(np.delete(run.joints, [0, 7], 0)).all()
    # sacrum = root translation, by the model's definition
    np.testing.assert_allclose(run.joints[1:7, 0], q[1:7, :3], atol=CSV_ROUNDING_M)


@pytest.mark.parametrize("run_up", AXES)
@pytest.mark.parametrize("out_up", AXES)
def test_file_rotation_is_proper_and_maps_up(run_up, out_up):
    P = file_rotation(run_up, out_up)
    np.testing.assert_allclose(P @ P.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(P) == pytest.approx(1.0)
    np.testing.assert_allclose(P @ axis_vector(run_up), axis_vector(out_up), atol=1e-12)
    if run_up == out_up:
        np.testing.assert_allclose(P, np.eye(3), atol=1e-12)


def test_sample_rate_follows_the_frame_step(tmp_path):
    q = np.zeros((4, NUM_DOF))
    assert sample_rate(read_run(write_run_dir(tmp_path / "a", q, fps=50.0,
                                              frames=[0, 2, 4, 6]))) == 25.0
    uneven = read_run(write_run_dir(tmp_path / "b", q, fps=50.0, frames=[0, 1, 3, 4]))
    with pytest.raises(IPFError, match="evenly spaced"):
        sample_rate(uneven)


@pytest.mark.parametrize("damage, file, message", [
    (lambda d: (d / "run.json").write_text('{"up_axis": "+z"}'), "run.json", "fps"),
    (lambda d: (d / "run.json").write_text('{"fps": 25, "up_axis": "up"}'), "run.json", "up_axis"),
    (lambda d: (d / "joints.csv").write_text(
        (d / "joints.csv").read_text().replace("sacrum_x", "pelvis_x")), "joints.csv", "sacrum_x"),
    (lambda d: (d / "poses.csv").write_text(
        (d / "poses.csv").read_text().replace("\n1,", "\n9,", 1)), "poses.csv", "increase"),
    (lambda d: (d / "joints.csv").unlink(), "joints.csv", "not found"),
])
def test_read_run_names_file_and_problem(tmp_path, damage, file, message):
    d = write_run_dir(tmp_path, np.zeros((3, NUM_DOF)))
    damage(d)
    with pytest.raises(IPFError, match=message) as info:
        read_run(d)
    assert info.value.path.endswith(file)


# --------------------------------------------------------------------------------------------------
# TRC


def opensim_fields(line: str) -> list[str]:
    """OpenSim's TRC tokenizer: split on tabs, keep empty fields, drop one trailing empty one."""
    fields = line.split("\t")
    return fields[:-1] if fields and fields[-1] == "" else fields


def parse_trc(text: str) -> tuple[dict, list[str], np.ndarray]:
    """A TRC as OpenSim's TRCFileAdapter reads it -> metadata, marker names, (T, 2 + 3 M) rows.

    Empty fields read as NaN; a row whose field count is not 3 M + 2 fails, as in OpenSim.
    """
    lines = text.splitlines()
    assert lines[0].split("\t")[:3] == ["PathFileType", "4", "(X/Y/Z)"]
    meta = dict(zip(lines[1].split("\t"), lines[2].split("\t")))
    names = [f for f in lines[3].split("\t") if f]
    n = int(meta["NumMarkers"])
    assert names[:2] == ["Frame#", "Time"] and len(names) == n + 2
    assert [f for f in lines[4].split("\t") if f] == [f"{a}{i}" for i in range(1, n + 1)
                                                     for a in "XYZ"]
    assert lines[5] == ""
    rows = [opensim_fields(line) for line in lines[6:]]
    assert all(len(r) == 3 * n + 2 for r in rows)
    return meta, names[2:], np.array([[float(f) if f else np.nan for f in r] for r in rows])


@pytest.mark.parametrize("up, units", [("+y", "mm"), ("+z", "m"), ("-z", "cm")])
def test_trc_round_trip(run_dir, tmp_path, up, units):
    run = read_run(run_dir)
    meta, names, rows = parse_trc(export_trc(run, tmp_path / "out.trc", up=up,
                                             units=units).read_text())
    assert names == list(POINT_NAMES) and meta["Units"] == units
    assert float(meta["DataRate"]) == 50.0 and int(meta["NumFrames"]) == 24
    np.testing.assert_array_equal(rows[:, 0], np.arange(1, 25))
    np.testing.assert_allclose(rows[:, 1], run.time_s, atol=1e-9)
    expected = to_file_frame(run.joints, run.up_axis, up, units)
    scale = {"m": 1.0, "cm": 100.0, "mm": 1000.0}[units]
    np.testing.assert_allclose(rows[:, 2:].reshape(24, 19, 3), expected,
                               atol=CSV_ROUNDING_M * scale, equal_nan=True)
    assert np.isnan(rows[[3, 4], 2:]).all()


def test_gait_reads_trc_and_c3d_exports(run_dir, tmp_path):
    """The gait module's readers see the same points (metres), up axis and clock."""
    run = read_run(run_dir)
    identity = tmp_path / "map.json"
    identity.write_text(json.dumps({p: p for p in POINT_NAMES}))
    for path, up in ((export_trc(run, tmp_path / "a.trc"), "+y"),
                     (export_c3d(run, tmp_path / "a.c3d"), run.up_axis)):
        traj = load_trajectories(path, marker_map=identity)
        assert traj.up_axis == up, path
        np.testing.assert_allclose(traj.time, run.time_s, atol=1e-6)
        expected = to_file_frame(run.joints, run.up_axis, up, "m")
        for j, name in enumerate(POINT_NAMES):
            np.testing.assert_allclose(traj.points[name], expected[:, j], atol=1e-6,
                                       equal_nan=True)


def test_trc_default_is_y_up(tmp_path):
    run = read_run(write_run_dir(tmp_path / "run", np.zeros((2, NUM_DOF)), up_axis="-z"))
    meta, _, rows = parse_trc(export_trc(run, tmp_path / "a.trc").read_text())
    points = rows[:, 2:].reshape(2, 19, 3)
    head, sacrum = points[0, POINT_NAMES.index("head")], points[0, 0]
    assert meta["Units"] == "mm"
    # zero pose stands: the head is straight above the sacrum, trunk + neck higher, in +Y
    np.testing.assert_allclose(head - sacrum, [0, 1000 * (0.49525 + 0.09625), 0], atol=1e-3)


# --------------------------------------------------------------------------------------------------
# C3D


@pytest.mark.parametrize("up, units", [(None, "mm"), ("+y", "m")])
def test_c3d_round_trip(run_dir, tmp_path, up, units):
    run = read_run(run_dir)
    path = export_c3d(run, tmp_path / "out.c3d", up=up, units=units)
    c3d = ezc3d.c3d(str(path))
    point = c3d["parameters"]["POINT"]
    assert list(point["LABELS"]["value"]) == list(POINT_NAMES)
    assert point["RATE"]["value"][0] == 50.0
    assert list(point["UNITS"]["value"]) == [units]
    out_up = up or run.up_axis
    assert point["Y_SCREEN"]["value"][0] == out_up.upper()
    positions = c3d["data"]["points"][:3].transpose(2, 1, 0)  # (T, J, 3)
    expected = to_file_frame(run.joints, run.up_axis, out_up, units)
    assert positions.shape == expected.shape
    float32 = 2 * np.finfo(np.float32).eps * np.nanmax(np.abs(expected))
    np.testing.assert_allclose(positions, expected, atol=float32, equal_nan=True)
    residuals = c3d["data"]["meta_points"]["residuals"][0].T  # (T, J)
    assert (residuals[[3, 4]] == -1).all() and (np.delete(residuals, [3, 4], 0) == 0).all()


def test_c3d_needs_the_suffix(run_dir, tmp_path):
    with pytest.raises(IPFError, match=r"\.c3d"):
        export_c3d(read_run(run_dir), tmp_path / "out.C3D")


# --------------------------------------------------------------------------------------------------
# BVH


@pytest.mark.parametrize("run_up", ["+z", "-z", "+y", "-x"])
def test_bvh_forward_kinematics_matches_joints(tmp_path, run_up):
    q = random_poses(np.random.default_rng(7), 60)
    run = read_run(write_run_dir(tmp_path / "run", q, up_axis=run_up, fps=25.0,
                                 shape=default_shape(1.62)))
    bvh = read_bvh(export_bvh(run, tmp_path / "out.bvh"))
    assert bvh.frame_time == pytest.approx(1 / 25.0) and len(bvh.motion) == 60
    positions = bvh_positions(bvh)[:, [bvh.names.index(BVH_SITE[p]) for p in POINT_NAMES]]
    expected = to_file_frame(run.joints, run_up, "+y", "m")
    tracked = np.isfinite(expected).all(axis=(1, 2))
    err = np.abs(positions[tracked] - expected[tracked]).max()
    assert err < BVH_TOL_M, f"BVH round trip off by {err * 1e3:.3f} mm"
    # missing frames 3 and 4 hold frame 2's pose
    np.testing.assert_allclose(positions[3], positions[2])
    np.testing.assert_allclose(positions[4], positions[2])


def test_bvh_units_and_up(tmp_path):
    run = read_run(write_run_dir(tmp_path / "run", random_poses(np.random.default_rng(3), 8)))
    metres = bvh_positions(read_bvh(export_bvh(run, tmp_path / "m.bvh")))
    mm = bvh_positions(read_bvh(export_bvh(run, tmp_path / "mm.bvh", units="mm")))
    np.testing.assert_allclose(mm / 1000, metres, atol=1e-6)
    for up in ("+z", "-x"):  # -x flips axes: exercises the signs folded into the angles
        other = read_bvh(export_bvh(run, tmp_path / "other.bvh", up=up))
        positions = bvh_positions(other)[:, [other.names.index(BVH_SITE[p]) for p in POINT_NAMES]]
        expected = to_file_frame(run.joints, run.up_axis, up, "m")
        ok = np.isfinite(expected).all(axis=(1, 2))
        assert np.abs(positions[ok] - expected[ok]).max() < BVH_TOL_M, up


def test_bvh_channels_suit_blender(tmp_path):
    run = read_run(write_run_dir(tmp_path / "run", np.zeros((2, NUM_DOF))))
    bvh = read_bvh(export_bvh(run, tmp_path / "a.bvh"))
    assert len(set(bvh.names)) == len(bvh.names) and bvh.parents[0] == -1
    assert bvh.channels[0][:3] == ("Xposition", "Yposition", "Zposition")
    for name, chans in zip(bvh.names, bvh.channels):
        rotations = sorted(c for c in chans if c.endswith("rotation"))
        if not name.endswith(".end"):
            # Blender's importer reads rotation channels only as complete triples
            assert rotations == ["Xrotation", "Yrotation", "Zrotation"], name
    assert (np.abs(bvh.offsets[0]) == 0).all()


def test_bvh_needs_poses_and_shape(tmp_path):
    d = write_run_dir(tmp_path / "run", np.zeros((2, NUM_DOF)))
    meta = json.loads((d / "run.json").read_text())
    del meta["shape"]
    (d / "run.json").write_text(json.dumps(meta))
    with pytest.raises(IPFError, match="shape"):
        export_bvh(read_run(d), tmp_path / "a.bvh")
    (d / "poses.csv").unlink()
    with pytest.raises(IPFError, match="poses.csv"):
        export_bvh(read_run(d), tmp_path / "a.bvh")
    all_missing = write_run_dir(tmp_path / "r2", np.full((2, NUM_DOF), np.nan))
    with pytest.raises(IPFError, match="no tracked frame"):
        export_bvh(read_run(all_missing), tmp_path / "a.bvh")


# --------------------------------------------------------------------------------------------------
# CSV and CLI


def test_csv_in_mm_and_another_up(run_dir, tmp_path):
    run = read_run(run_dir)
    path = export_csv(run, tmp_path / "j.csv", up="+y", units="mm")
    header = path.read_text().splitlines()[0].split(",")
    assert header[:3] == ["frame", "time_s", "sacrum_x_mm"] and len(header) == 2 + 57
    data = np.loadtxt(path, delimiter=",", skiprows=1)
    np.testing.assert_array_equal(data[:, 0], run.frames)
    expected = to_file_frame(run.joints, run.up_axis, "+y", "mm").reshape(24, -1)
    np.testing.assert_allclose(data[:, 2:], expected, atol=1e-3, equal_nan=True)
    same = export_csv(run, tmp_path / "same.csv")
    assert same.read_text() == (run_dir / "joints.csv").read_text()


@pytest.mark.parametrize("suffix", ["trc", "c3d", "bvh", "csv"])
def test_cli_writes_each_format(run_dir, tmp_path, suffix, capsys):
    out = tmp_path / f"out.{suffix}"
    assert main(["export", str(run_dir), "--out", str(out)]) == 0
    assert out.stat().st_size > 0
    assert "24 frames" in capsys.readouterr().out


def test_cli_errors_are_one_line(run_dir, tmp_path, capsys):
    assert main(["export", str(run_dir), "--out", str(tmp_path / "x.foo")]) == 2
    assert main(["export", str(tmp_path / "none"), "--out", str(tmp_path / "x.trc")]) == 2
    (run_dir / "run.json").write_text("{")
    assert main(["export", str(run_dir), "--format", "trc", "--up=-x", "--units", "m",
                 "--out", str(tmp_path / "x")]) == 2
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 3 and all(line.startswith("error: ") for line in lines)
    assert "x.foo" in lines[0] and "none" in lines[1] and "run.json" in lines[2]


def test_smoothed_joints_are_the_gait_filter_of_the_raw_ones_and_raw_is_kept(tmp_path):
    from ipf_jax.analysis.export.smoothed import NAME, smooth_joints, write_smoothed
    from ipf_jax.analysis.gait.filtering import lowpass
    from ipf_jax.data.runfiles import read_joints_csv
    from ipf_jax.geometry.posing import gait_pose

    rng = np.random.default_rng(3)
    poses = np.stack([gait_pose(20 * np.sin(t / 3), -20 * np.sin(t / 3), 10, 10) for t in range(30)])
    poses[:, 0] = np.linspace(0, 1.5, 30) + rng.normal(0, 0.01, 30)  # jitter to remove
    poses[12] = np.nan  # a missing frame stays missing
    run_dir = write_run_dir(tmp_path / "run", poses, fps=20.0)
    raw_before = (run_dir / "joints.csv").read_bytes()
    path = write_smoothed(run_dir)
    assert path.name == NAME and (run_dir / "joints.csv").read_bytes() == raw_before
    smooth = read_joints_csv(path).points
    raw = read_run(run_dir)
    expected = lowpass(raw.joints, 20.0, 5.0)
    assert np.allclose(smooth, expected, atol=1e-6, equal_nan=True)
    assert np.isnan(smooth[12]).all() and np.isfinite(smooth[:12]).all()
    jitter = lambda j: np.abs(np.diff(j[:12, 0, 0], 2)).mean()  # noqa: E731
    assert jitter(smooth) < 0.5 * jitter(raw.joints)
    assert smooth_joints(raw)[1] == 5.0  # the cut-off used at 20 Hz
    out = tmp_path / "s.csv"
    assert main(["export", str(run_dir), "--format", "csv", "--out", str(out), "--smooth"]) == 0
    assert np.allclose(read_joints_csv(out).points, expected, atol=1e-6, equal_nan=True)
    assert main(["export", str(run_dir), "--format", "bvh", "--out", str(tmp_path / "b.bvh"),
                 "--smooth"]) == 2
