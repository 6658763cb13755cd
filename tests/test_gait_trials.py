"""Gait events of real lab trials against their force plates (``gait_trials`` and Rajagopal).

Every force-plate event of every trial must be found within max(2 frames, 20 ms) for heel
strikes and max(3 frames, 30 ms) for toe-offs, both with the trial's ``truth.json`` marker map and
with none (the marker set recognised from the labels). ``truth.json`` times count from the first
stored frame; ``ipf-jax gait`` keeps the file's own clock, ``(first_frame + i) / rate``, so
``time_offset_s`` is added to the truth. The Rajagopal plate events are derived from
``grf_walk.mot`` here (vertical force > 20 N, interpolated at 2000 Hz).

The step times, stances and double supports the plates observe are compared too, each within the
sum of its two events' tolerances.
"""
from __future__ import annotations

import json

import numpy as np
import pytest

from ipf_jax.analysis.gait import analyse, load

TRIALS = ("qualisys_ezc3d", "vicon_pig_btk", "vicon_functionalwalk_btk", "vicon_c3dorg_sample09",
          "vicon_smk_overground", "motionanalysis_btk_gait")
RAJAGOPAL_CONTACTS = {"right": [(0.2675, 1.0234), (1.4120, 2.1674)], "left": [(0.8363, 1.5892)]}


def hs_tol(fps: float) -> float:
    return max(2.0 / fps, 0.020)


def to_tol(fps: float) -> float:
    return max(3.0 / fps, 0.030)


@pytest.fixture(scope="module")
def trials_dir(shared_data):
    return shared_data("gait_trials")


@pytest.fixture(scope="module")
def analysed(trials_dir, tmp_path_factory):
    """trial -> (truth, {"map": GaitResult, "auto": GaitResult})."""
    out = {}
    maps = tmp_path_factory.mktemp("maps")
    for name in TRIALS:
        truth = json.loads((trials_dir / name / "truth.json").read_text())
        path = trials_dir / name / truth["file"]
        mp = maps / f"{name}.json"
        mp.write_text(json.dumps({"name": name, "roles": truth["marker_map"]}))
        out[name] = (truth, {"map": analyse(load(path, marker_map=mp)),
                             "auto": analyse(load(path))})
    return out


def event_errors(result, truth: dict) -> list:
    """(event, truth time, detected time or None, error or None, tolerance) per plate event."""
    fps, off = truth["marker_rate_hz"], truth["time_offset_s"]
    rows = []
    for name, items in truth["events"].items():
        tol = hs_tol(fps) if "heel" in name else to_tol(fps)
        found = result.events[name] - off
        for item in items:
            t = item["time_s"]
            if found.size == 0:
                rows.append((name, t, None, None, tol))
                continue
            d = float(found[np.argmin(np.abs(found - t))])
            rows.append((name, t, d, d - t, tol))
    return rows


@pytest.mark.parametrize("how", ["map", "auto"])
@pytest.mark.parametrize("trial", TRIALS)
def test_every_plate_event_is_found_within_tolerance(analysed, trial, how):
    truth, results = analysed[trial]
    res = results[how]
    rows = event_errors(res, truth)
    assert len(rows) == truth["n_events"]
    bad = [f"{n} {t:.4f}: " + ("none found" if e is None else f"{1000 * e:+.1f} ms")
           for n, t, _, e, tol in rows if e is None or abs(e) > tol]
    assert not bad, f"{trial} ({how} markers, {res.method}): {bad}"
    assert res.method == "contact"
    assert [p.heading.mode for p in res.parts] == ["overground"] * len(res.parts)


def test_auto_recognition_names_the_marker_set(analysed):
    sets = {name: next(n for n in res["auto"].notes if n.startswith("marker set"))
            for name, (_, res) in analysed.items()}
    assert "Qualisys" in sets["qualisys_ezc3d"]
    assert "Helen Hayes" in sets["motionanalysis_btk_gait"]
    assert all("Plug-in Gait" in sets[n] for n in TRIALS if n.startswith("vicon"))
    # FunctionalWalk's SACR is present but empty: the PSIS stand in, and the note says so
    walk = analysed["vicon_functionalwalk_btk"][1]["auto"]
    assert any("SACR present but never has data" in n for n in walk.notes)
    # Qualisys states POINT:Y_SCREEN -Z for a +Z-up lab: the body decides
    assert analysed["qualisys_ezc3d"][1]["auto"].up_axis == "+z"


def _steps_from_plates(truth):
    """(first HS, second HS, step time, double support) of each plate-observed step.

    The plates' double support is the overlap of the two contacts: from the second heel strike
    to the first foot's toe-off, i.e. the double support that starts the *next* step.
    """
    contacts = [c for c in truth["contacts"] if c["valid"]]
    out = []
    for step in truth["steps"]:
        first = next(c for c in contacts if f"{c['side']} HS {c['plate']}" == step["from"])
        second = next(c for c in contacts if f"{c['side']} HS {c['plate']}" == step["to"])
        out.append((first["heel_strike_s"], second["heel_strike_s"], step["step_time_s"],
                    step["double_support_s"]))
    return out


@pytest.mark.parametrize("trial", TRIALS)
def test_step_time_stance_and_double_support_match_the_plates(analysed, trial):
    truth, results = analysed[trial]
    res = results["auto"]
    fps, off = truth["marker_rate_hz"], truth["time_offset_s"]
    checked = 0
    for t0, t1, step_time, ds in _steps_from_plates(truth):
        step = min(res.steps, key=lambda s: abs(s.start_s - off - t0))
        assert abs(step.start_s - off - t0) <= hs_tol(fps)
        assert abs(step.step_time_s - step_time) <= 2 * hs_tol(fps), (trial, step, step_time)
        # the detected double support after the second strike: toe-off of the first foot
        first_off = res.events[f"{'left' if step.side == 'right' else 'right'}_toe_off"] - off
        after = first_off[first_off > step.end_s - off]
        assert after.size and abs((after[0] - (step.end_s - off)) - ds) <= (
            hs_tol(fps) + to_tol(fps)), (trial, step, ds)
        checked += 1
    for c in truth["contacts"]:
        if not c["valid"] or "dropped" in " ".join(c["reasons"]):
            continue
        hs = res.events[f"{c['side']}_heel_strike"] - off
        to = res.events[f"{c['side']}_toe_off"] - off
        t_hs = hs[np.argmin(np.abs(hs - c["heel_strike_s"]))]
        t_to = to[np.argmin(np.abs(to - c["toe_off_s"]))]
        assert abs((t_to - t_hs) - c["stance_s"]) <= hs_tol(fps) + to_tol(fps)
        checked += 1
    assert checked >= 1


def test_walking_speed_matches_the_pelvis(analysed):
    for name, (truth, results) in analysed.items():
        speed = results["auto"].fall_risk["walking_speed_m_s"]["value"]
        assert speed == pytest.approx(truth["walking_speed_m_s"], rel=0.12), name


@pytest.fixture(scope="module")
def rajagopal(shared_data):
    folder = shared_data("opensim_walk/Rajagopal")
    return analyse(load(folder / "motion_capture_walk.trc"))


def test_rajagopal_plate_events(rajagopal):
    res = rajagopal
    assert res.method == "contact"
    for side, contacts in RAJAGOPAL_CONTACTS.items():
        for on, off in contacts:
            hs, to = res.events[f"{side}_heel_strike"], res.events[f"{side}_toe_off"]
            assert np.min(np.abs(hs - on)) <= hs_tol(100.0), (side, on, hs)
            assert np.min(np.abs(to - off)) <= to_tol(100.0), (side, off, to)
