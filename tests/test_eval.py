"""``ipf-jax eval``: hand-computed MPJPE across frame rates, joint choice, rigid alignment, errors."""
import json

import numpy as np
import pytest

from ipf_jax.analysis.evaluation import evaluate_files
from ipf_jax.analysis.evaluation.align import resample, rigid_fit
from ipf_jax.body.model import LIMB_JOINTS, POINT_NAMES
from ipf_jax.cli import main
from ipf_jax.data.runfiles import read_joints_csv

TOL = 1e-12  # metres: files hold 9 decimals, the arithmetic is exact to rounding


def write_table(path, times, points, names, *, extra=False):
    """joints.csv convention (optionally with an extra column, as ground_truth.csv has)."""
    head = ["frame", "time_s"] + (["source_time_s"] if extra else []) + [f"{n}_{a}" for n in names for a in "xyz"]
    rows = [",".join(head)]
    for i, (t, p) in enumerate(zip(times, points)):
        vals = [str(i), f"{t:.9f}"] + ([f"{t + 0.25:.9f}"] if extra else [])
        vals += ["nan" if not np.isfinite(v) else f"{v:.9f}" for v in np.asarray(p).ravel()]
        rows.append(",".join(vals))
    path.write_text("\n".join(rows) + "\n")
    return path


def knees(t):
    """(T, 2, 3): a left knee moving linearly, a right knee with a curved height."""
    t = np.asarray(t, float)
    left = np.stack([2 * t, np.full_like(t, 0.1), np.full_like(t, 0.5)], -1)
    right = np.stack([2 * t, np.full_like(t, -0.1), 0.5 + t ** 2], -1)
    return np.stack([left, right], 1)


@pytest.fixture()
def vicon_vs_video(tmp_path):
    """A 100 Hz reference (with a head the estimate lacks) and a 20 Hz estimate with known errors."""
    t_ref = np.arange(21) / 100.0  # 0 .. 0.20 s
    ref = np.concatenate([knees(t_ref), np.tile([[[0.0, 0.0, 1.7]]], (21, 1, 1))], 1)
    truth = write_table(tmp_path / "truth.csv", t_ref, ref, ["left_knee", "right_knee", "head"], extra=True)
    t_est = np.arange(6) / 20.0  # 0 .. 0.25 s: the last frame is past the reference
    est = knees(t_est)
    est[:, 0] += [0.03, 0.04, 0.0]  # left knee: 5 cm off on every frame
    est[:, 1, 2] += [0.1, 0.2, 0.0, 0.3, 0.2, 0.1]  # right knee: 10, 20, -, 30, 20, 10 cm high
    est[2] = np.nan  # a frame the tracker missed
    estimate = write_table(tmp_path / "joints.csv", t_est, est, ["left_knee", "right_knee"])
    return estimate, truth


def test_20hz_estimate_against_100hz_truth_matches_hand_computation(vicon_vs_video, tmp_path):
    estimate, truth = vicon_vs_video
    ev, _, _ = evaluate_files(estimate, truth)
    # scored frames 0, 1, 3, 4 (2 missing, 5 after the truth ends):
    # left 0.05 x 4, right 0.1 + 0.2 + 0.3 + 0.2 -> (0.2 + 0.8) / 8
    assert ev.mpjpe_m == pytest.approx(0.125, abs=TOL)
    assert ev.per_joint_m == pytest.approx({"left_knee": 0.05, "right_knee": 0.2}, abs=TOL)
    assert ev.rms_axis_m["x"] == pytest.approx(np.sqrt(4 * 0.03 ** 2 / 8), abs=TOL)
    assert ev.rms_axis_m["y"] == pytest.approx(np.sqrt(4 * 0.04 ** 2 / 8), abs=TOL)
    assert ev.rms_axis_m["z"] == pytest.approx(np.sqrt((0.01 + 0.04 + 0.09 + 0.04) / 8), abs=TOL)
    assert main(["eval", str(estimate), str(truth), "--out", str(tmp_path / "ev")]) == 0
    doc = json.loads((tmp_path / "ev" / "eval.json").read_text())  # 6 decimals: micrometres
    assert doc["mpjpe_m"] == 0.125 and doc["per_joint_m"] == {"left_knee": 0.05, "right_knee": 0.2}
    assert doc["rms_axis_m"] == {k: round(v, 6) for k, v in ev.rms_axis_m.items()}
    assert (doc["n_frames"], doc["n_frames_outside_truth"], doc["n_frames_incomplete"]) == (4, 1, 1)
    assert doc["scored_joints"] == ["left_knee", "right_knee"]  # no limb set: every shared name
    assert doc["align"]["mode"] == "none"
    rows = (tmp_path / "ev" / "per_frame.csv").read_text().splitlines()
    assert rows[0] == "frame,time_s,scored,mpjpe_m,left_knee_m,right_knee_m"
    assert [r.split(",")[2] for r in rows[1:]] == ["1", "1", "0", "1", "1", "0"]
    assert float(rows[4].split(",")[3]) == pytest.approx((0.05 + 0.3) / 2, abs=1e-6)
    assert (tmp_path / "ev" / "displacement.png").stat().st_size > 10_000


def test_truth_is_interpolated_between_its_samples(tmp_path):
    t_ref = np.arange(21) / 100.0
    truth = write_table(tmp_path / "truth.csv", t_ref, knees(t_ref), ["left_knee", "right_knee"])
    t_est = 0.005 + np.arange(4) / 20.0  # halfway between 100 Hz samples
    estimate = write_table(tmp_path / "est.csv", t_est, knees(t_est), ["left_knee", "right_knee"])
    ev, _, _ = evaluate_files(estimate, truth)
    # linear motion interpolates exactly; t^2 midway between t-h and t+h is off by h^2 = 2.5e-5 m
    np.testing.assert_allclose(ev.errors[:, 0], 0.0, atol=TOL)
    np.testing.assert_allclose(ev.errors[:, 1], 0.005 ** 2, atol=1e-9)
    assert ev.mpjpe_m == pytest.approx(0.005 ** 2 / 2, abs=1e-9)


def test_sparse_truth_at_a_dense_estimate_and_outside_range():
    t_ref = np.array([0.0, 0.1, 0.2])
    ref = np.arange(3.0)[:, None, None] * np.ones((3, 1, 3))  # 0, 1, 2 m along every axis
    got, inside = resample(np.array([-0.01, 0.0, 0.05, 0.1 + 1e-8, 0.15, 0.2, 0.21]), t_ref, ref)
    assert inside.tolist() == [False, True, True, True, True, True, False]
    np.testing.assert_allclose(got[inside, 0, 0], [0.0, 0.5, 1.0, 1.5, 2.0], atol=TOL)


def full_body(t, offset=0.0):
    """(T, 19, 3) points of the body model's 19 names moving along x."""
    base = np.random.default_rng(3).normal(size=(len(POINT_NAMES), 3))
    return base[None] + np.stack([np.asarray(t) * 1.2, 0 * np.asarray(t), 0 * np.asarray(t)], -1)[:, None] + offset


def test_limb_joints_are_scored_and_joints_option_chooses(tmp_path):
    t = np.arange(5) / 20.0
    ref = full_body(t)
    est = ref.copy()
    est[:, [POINT_NAMES.index(j) for j in LIMB_JOINTS], 2] += 0.02  # limbs 2 cm off
    est[:, POINT_NAMES.index("sacrum"), 0] += 1.0  # marker conventions differ: not scored
    truth = write_table(tmp_path / "t.csv", t, ref, POINT_NAMES)
    estimate = write_table(tmp_path / "e.csv", t, est, POINT_NAMES)
    ev, _, _ = evaluate_files(estimate, truth)
    assert ev.scored == LIMB_JOINTS
    assert ev.mpjpe_m == pytest.approx(0.02, abs=TOL)
    assert ev.per_joint_m["sacrum"] == pytest.approx(1.0, abs=TOL)
    ev, _, _ = evaluate_files(estimate, truth, joints=["sacrum", "neck"])
    assert ev.mpjpe_m == pytest.approx(0.5, abs=TOL)


def test_rigid_alignment_removes_a_rotation_and_translation(tmp_path):
    t = np.arange(8) / 20.0
    ref = full_body(t)
    a = np.deg2rad(30)
    rot = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
    est = ref @ rot.T + [0.4, -0.2, 0.1]  # the estimate lives in another world frame
    truth = write_table(tmp_path / "t.csv", t, ref, POINT_NAMES)
    estimate = write_table(tmp_path / "e.csv", t, est, POINT_NAMES)
    assert evaluate_files(estimate, truth)[0].mpjpe_m > 0.2
    ev, _, _ = evaluate_files(estimate, truth, align="rigid")
    assert ev.mpjpe_m < 1e-8
    np.testing.assert_allclose(ev.align["rotation"], rot.T, atol=1e-8)
    assert main(["eval", str(estimate), str(truth), "--out", str(tmp_path / "ev"), "--align", "rigid",
                 "--no-plots"]) == 0
    doc = json.loads((tmp_path / "ev" / "eval.json").read_text())
    assert doc["align"]["mode"] == "rigid" and "no scale" in doc["align"]["note"]


def test_rigid_fit_never_mirrors():
    pts = np.random.default_rng(0).normal(size=(20, 3))
    rot, _ = rigid_fit(pts, pts * [1, 1, -1])  # a mirror image: the best rotation, not a reflection
    assert np.linalg.det(rot) == pytest.approx(1.0)


def test_reads_real_ground_truth(shared_data, tmp_path):
    gt = shared_data("mocap_walk_render/rajagopal_walk_clean_4cam") / "ground_truth.csv"
    table = read_joints_csv(gt)
    shifted = write_table(tmp_path / "e.csv", table.time_s, table.points + [0.0, 0.0, 0.01], table.names)
    ev, _, _ = evaluate_files(shifted, gt)
    assert ev.scored == LIMB_JOINTS and int(ev.scored_frames.sum()) == 32
    assert ev.mpjpe_m == pytest.approx(0.01, abs=1e-8)


@pytest.mark.parametrize("case, message", [
    ("no_shared", "share no point name"),
    ("no_overlap", "no frame to score"),
    ("bad_time", "time_s must increase strictly"),
    ("estimate_time", "time_s must increase strictly from row to row (rows 1 and 2"),
    ("twice", "column(s) left_knee_x appear more than once"),
    ("bad_joint", "--joints names nose not in both files"),
])
def test_user_mistakes_are_one_line(tmp_path, capsys, case, message):
    t = np.arange(4) / 20.0
    truth = write_table(tmp_path / "t.csv", t, knees(t), ["left_knee", "right_knee"])
    args = []
    if case == "no_shared":
        est = write_table(tmp_path / "e.csv", t, knees(t), ["a", "b"])
    elif case == "no_overlap":
        est = write_table(tmp_path / "e.csv", t + 5.0, knees(t), ["left_knee", "right_knee"])
    elif case == "bad_time":
        est = truth
        truth = write_table(tmp_path / "t2.csv", t[::-1], knees(t), ["left_knee", "right_knee"])
    elif case == "estimate_time":  # every row at one time (a run written with a wrong frame rate)
        est = write_table(tmp_path / "e.csv", np.zeros(4), knees(t), ["left_knee", "right_knee"])
    elif case == "twice":  # a column pasted twice: which one is the data?
        est = tmp_path / "e.csv"
        lines = truth.read_text().splitlines()
        est.write_text("\n".join([lines[0] + ",left_knee_x"] + [ln + ",9" for ln in lines[1:]]) + "\n")
    else:
        est, args = truth, ["--joints", "left_knee,nose"]
    assert main(["eval", str(est), str(truth), "--out", str(tmp_path / "ev")] + args) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: ") and message in err and "\n" not in err


def test_constant_offset_and_offset_free_error_by_hand(vicon_vs_video):
    """Left knee 5 cm off on every frame: all offset, nothing left. Right knee 10/20/30/20 cm high:
    an offset of 20 cm straight up, and 5 cm left on average (10, 0, 10, 0 cm) once removed."""
    estimate, truth = vicon_vs_video
    ev, _, _ = evaluate_files(estimate, truth)
    sp = ev.split
    assert sp.names == ("left_knee", "right_knee")
    assert sp.offset[0] == pytest.approx([0.03, 0.04, 0.0], abs=TOL)
    assert sp.offset[1] == pytest.approx([0.0, 0.0, 0.2], abs=TOL)
    assert sp.offset_m == pytest.approx([0.05, 0.2], abs=TOL)
    assert sp.offset_free_m == pytest.approx([0.0, 0.05], abs=TOL)
    from ipf_jax.analysis.evaluation.metrics import systematic_doc

    doc = systematic_doc(ev)
    assert doc["mpjpe_offset_free_m"] == pytest.approx(0.025, abs=1e-6)
    assert doc["mean_offset_m"] == pytest.approx(0.125, abs=1e-6)
    assert doc["mean_leg_offset_m"] == pytest.approx(0.125, abs=1e-6)


def test_lost_frames_and_recovery_count():
    from ipf_jax.analysis.evaluation.metrics import loss_summary

    e = np.array([0.05, 0.25, 0.30, 0.15, 0.08, 0.21, 0.09, 0.5])
    doc = loss_summary(e)
    assert doc["lost_frames"] == 4 and doc["longest_lost_run"] == 2
    assert doc["recoveries_frames"] == [3, 1, None]  # 0.25 -> 0.08 three frames on; 0.5 never
    assert doc["worst5_mean_m"] == pytest.approx((0.5 + 0.3 + 0.25 + 0.21 + 0.15) / 5)


def test_joints_in_millimetres_are_refused_not_scored(tmp_path):
    from ipf_jax.data.runfiles import JOINT_COLUMNS, read_joints_csv
    from ipf_jax.errors import IPFError

    row = np.zeros(len(JOINT_COLUMNS))
    names = [c[:-2] for c in JOINT_COLUMNS[2::3]]
    row[2 + 3 * names.index("left_knee") + 2] = -0.42  # a 0.42 m thigh, in metres
    row[2 + 3 * names.index("right_knee") + 2] = -0.42
    head = ",".join(JOINT_COLUMNS)
    (tmp_path / "m.csv").write_text(head + "\n" + ",".join(map(str, row)) + "\n")
    read_joints_csv(tmp_path / "m.csv")
    mm = row.copy()
    mm[2:] *= 1000.0
    (tmp_path / "mm.csv").write_text(head + "\n" + ",".join(map(str, mm)) + "\n")
    with pytest.raises(IPFError, match=r"thighs \(hip to knee\) measure 420 .*must be metres"):
        read_joints_csv(tmp_path / "mm.csv")
