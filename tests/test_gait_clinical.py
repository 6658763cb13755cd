"""Gait-lab conventions: marker sets recognised, gaps never read as positions, cadence over steps,
physiological bounds, overground vs treadmill with a margin, fall-risk measures (issue 18)."""
from __future__ import annotations

import numpy as np
import pytest

from ipf_jax.analysis.gait import analyse, load
from ipf_jax.analysis.gait.events import FootEvents
from ipf_jax.analysis.gait.markersets import MARKER_SETS
from ipf_jax.analysis.gait.parameters import (
    Step,
    Stride,
    apply_bounds,
    cadence_and_speed,
    drop_close_strikes,
)
from ipf_jax.analysis.gait.synthetic import synthetic_walk
from ipf_jax.errors import IPFError

#: role -> label in each recognised set (one representative alternative per role)
LABELS = {
    "Plug-in Gait": {"sacrum": "SACR", "left_heel": "LHEE", "right_heel": "RHEE",
                     "left_toe": "LTOE", "right_toe": "RTOE", "left_ankle": "LANK",
                     "right_ankle": "RANK"},
    "Helen Hayes": {"sacrum": "VSAC", "left_heel": "LHEE", "right_heel": "RHEE",
                    "left_toe": "LTOE", "right_toe": "RTOE"},
    "Qualisys": {"left_heel": "L_FCC", "right_heel": "R_FCC", "left_toe": "L_FM1",
                 "right_toe": "R_FM1"},
    "Davis": {"sacrum": "sacrum", "left_heel": "l heel", "right_heel": "r heel",
              "left_toe": "l met", "right_toe": "r met"},
    "Rajagopal": {"sacrum": "S2", "left_heel": "L.Heel", "right_heel": "R.Heel",
                  "left_toe": "L.Toe", "right_toe": "R.Toe"},
    "ipf-jax": {r: r for r in ("sacrum", "left_heel", "right_heel", "left_toe", "right_toe")},
}


def write_trc(path, columns: dict, time: np.ndarray, *, units="mm"):
    """A TRC file of label -> (T, 3) metres (written in ``units``), every field tab-terminated."""
    scale = {"mm": 1000.0, "m": 1.0}[units]
    names = list(columns)
    lines = [f"PathFileType\t4\t(X/Y/Z)\t{path.name}",
             ("DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits\tOrigDataRate\t"
              "OrigDataStartFrame\tOrigNumFrames"),
             "\t".join(map(str, (100, 100, len(time), len(names), units, 100, 1, len(time)))),
             "Frame#\tTime\t" + "".join(f"{n}\t\t\t" for n in names),
             "\t\t" + "".join(f"X{i}\tY{i}\tZ{i}\t" for i in range(1, len(names) + 1)), ""]
    for i, t in enumerate(time):
        vals = "".join("\t".join(f"{v * scale:.4f}" for v in columns[n][i]) + "\t"
                       for n in names)
        lines.append(f"{i + 1}\t{t:.5f}\t{vals}")
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.fixture(scope="module")
def walk():
    return synthetic_walk(duration_s=5.0, fps=100.0, up_axis="+z", heading_deg=20.0)


def _columns(traj, labels: dict) -> dict:
    cols = {}
    for role, label in labels.items():
        cols[label] = traj.points[role]
    if "sacrum" not in labels:  # Qualisys: sacrum = mean of the two PSIS
        cols["L_IPS"] = traj.points["sacrum"] + [0.0, 0.05, 0.0]
        cols["R_IPS"] = traj.points["sacrum"] - [0.0, 0.05, 0.0]
    return cols


@pytest.mark.parametrize("set_name", list(LABELS))
def test_each_marker_set_is_recognised_without_a_map(tmp_path, walk, set_name):
    traj, truth = walk
    path = write_trc(tmp_path / "walk.trc", _columns(traj, LABELS[set_name]), traj.time)
    back = load(path)
    assert any(n.startswith("marker set recognised") and set_name.split()[0] in n
               for n in back.notes), back.notes
    assert back.up_axis == "+z"  # from the body: a TRC states none
    np.testing.assert_allclose(back.points["left_heel"], traj.points["left_heel"], atol=1e-6)
    res = analyse(back)
    assert res.lab["cadence_steps_per_min"] == pytest.approx(truth.cadence_steps_per_min,
                                                             abs=1.0)


def test_every_set_is_listed_and_an_unknown_one_is_one_clear_error(tmp_path, walk):
    assert len(MARKER_SETS) == 6
    traj, _ = walk
    cols = {"PELVIS_X": traj.points["sacrum"], "FOOT_A": traj.points["left_heel"]}
    path = write_trc(tmp_path / "odd.trc", cols, traj.time)
    with pytest.raises(IPFError) as info:
        load(path)
    msg = str(info.value)
    assert "odd.trc" in msg and "no known marker set" in msg
    assert "PELVIS_X" in msg and "--marker-map" in msg and "Davis" in msg


def test_zeros_are_gaps_never_positions(tmp_path, walk):
    """A Davis trial whose markers are stored as zeros before they are seen (BTS)."""
    traj, _ = walk
    cols = _columns(traj, LABELS["Davis"])
    blind = traj.time < traj.time[0] + 2.0
    for xyz in cols.values():
        xyz[blind] = 0.0
    back = load(write_trc(tmp_path / "davis.trc", cols, traj.time))
    assert np.isnan(back.points["sacrum"][blind]).all()
    assert any("(0, 0, 0) read as missing" in n for n in back.notes)
    res = analyse(back)
    first = min(min(v) for v in res.events.values() if len(v))
    assert first > traj.time[0] + 2.0
    assert res.lab["cadence_steps_per_min"] == pytest.approx(108.0, abs=1.0)


def test_short_nan_gaps_are_bridged_and_stated(walk):
    traj, truth = walk
    pts = {k: v.copy() for k, v in traj.points.items()}
    pts["left_heel"][200:205] = np.nan
    res = analyse(traj._replace(points=pts))
    assert any("interpolated" in n for n in res.notes)
    assert res.lab["cadence_steps_per_min"] == pytest.approx(truth.cadence_steps_per_min, abs=1)


def test_cadence_is_steps_over_time_and_a_spurious_last_step_is_dropped():
    none = np.empty(0)
    events = {"left": FootEvents(np.array([0.6, 1.8]), none),
              "right": FootEvents(np.array([0.0, 1.2, 1.92]), none)}  # 1.92: 0.12 s after 1.8
    kept, rejected = drop_close_strikes(events, 0.0, 1.95)
    assert list(kept["right"].heel_strike) == [0.0, 1.2]
    assert len(rejected) == 1 and rejected[0].start_s == 1.92
    strikes = sorted((t, s) for s in ("left", "right") for t in kept[s].heel_strike)
    lab = cadence_and_speed([(0, "overground", strikes, lambda t: 1.2 * t)], [])
    assert lab["steps"] == 3 and lab["cadence_steps_per_min"] == pytest.approx(100.0)
    assert lab["walking_speed_m_s"] == pytest.approx(1.2)
    # a missed strike of the other foot: the same-foot interval is two steps
    lab = cadence_and_speed([(0, "overground", [(0.0, "r"), (0.6, "l"), (1.8, "l")],
                              lambda t: t)], [])
    assert lab["steps"] == 3 and lab["cadence_steps_per_min"] == pytest.approx(100.0)


def test_steps_outside_the_physiological_bounds_are_rejected():
    ok = Step(0, "left", 0.0, 0.55, 0.55, 0.65, 0.12, 0.2, 0.2, 0.35)
    slow = ok._replace(start_s=1.0, end_s=4.0, step_time_s=3.0)
    wide = ok._replace(step_width_m=0.9)
    stride = Stride(0, "left", 0.0, 1.1, 1.1, 1.3, 1.18, 0.68, 0.42, 0.26, 0.42)
    flight = stride._replace(double_support_s=-0.05)
    steps, strides, rejected = apply_bounds([ok, slow, wide], [stride, flight])
    assert steps == [ok] and strides == [stride]
    reasons = [r.reason for r in rejected]
    assert any("step_time_s 3" in r and "[0.3, 2.5]" in r for r in reasons)
    assert any("step_width_m 0.9" in r for r in reasons)
    assert any("double_support_s" in r for r in reasons)


def test_a_short_clip_where_the_pelvis_moves_is_overground_and_says_so():
    # 12 frames, 0.55 s, 0.66 m: too short for the feet to decide
    traj, _ = synthetic_walk(duration_s=0.6, fps=20.0, speed=1.2)
    assert len(traj.time) == 12
    res = analyse(traj)
    assert [p.heading.mode for p in res.parts] == ["overground"]
    note = next(n for n in res.notes if "overground" in n)
    assert "too short" in note and "the pelvis moves" in note


def test_treadmill_and_overground_are_decided_with_a_margin():
    tread = analyse(synthetic_walk(treadmill=True, heading_deg=60.0)[0])
    assert [p.heading.mode for p in tread.parts] == ["treadmill"]
    note = next(n for n in tread.notes if n.startswith("treadmill walking"))
    ratio = float(note.split("ratio ")[1].split(";")[0])
    assert ratio < 0.1  # far inside the treadmill margin (<= 0.3)
    over = analyse(synthetic_walk()[0])
    note = next(n for n in over.notes if n.startswith("overground walking"))
    assert float(note.split("ratio ")[1].split(";")[0]) > 0.9


def test_fall_risk_measures_and_the_speed_reference(walk):
    slow = analyse(synthetic_walk(duration_s=8.0, speed=0.6, cadence=90.0)[0])
    fr = slow.fall_risk
    for key in ("walking_speed_m_s", "cadence_steps_per_min", "stride_time_sd_s",
                "stride_time_cv_pct", "step_length_sd_m", "step_length_cv_pct",
                "double_support_pct", "step_width_sd_m", "symmetry_step_length_pct",
                "symmetry_step_time_pct", "symmetry_stance_pct", "symmetry_swing_pct"):
        assert key in fr, key
    assert fr["walking_speed_m_s"]["value"] == pytest.approx(0.6, abs=0.02)
    assert fr["walking_speed_m_s"]["flag"] == "below 0.8"
    assert "World guidelines" in fr["walking_speed_m_s"]["reference"]["source"]
    assert fr["cadence_steps_per_min"]["value"] == pytest.approx(90.0, abs=1.0)
    # a regular synthetic walk: stride time barely varies; double support from its stance 62 %
    assert fr["stride_time_cv_pct"]["value"] < 1.0
    assert fr["double_support_pct"]["value"] == pytest.approx(2 * (62 - 50), abs=4)
    assert analyse(walk[0]).fall_risk["walking_speed_m_s"]["flag"] is None  # 1.2 m/s


def test_a_jump_in_the_clock_splits_the_trial(walk):
    traj, truth = walk
    time = traj.time.copy()
    time[250:] += 2.0  # 2 s missing from the record (frames skipped)
    res = analyse(traj._replace(time=time))
    assert any("jumps in the clock" in n for n in res.notes)
    assert len(res.parts) == 2
    assert all(not (time[249] < s.end_s and s.start_s < time[250]) for s in res.steps)
    assert res.lab["cadence_steps_per_min"] == pytest.approx(truth.cadence_steps_per_min, abs=1)
