"""The gait analysis pipeline: trajectories -> filtered straight parts -> events -> parameters.

:func:`analyse` is the library entry point; :mod:`.report` writes its :class:`GaitResult` to disk.
Nothing here reads files or prints, so the pipeline is easy to test on synthetic walks.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ...errors import IPFError
from . import angles as angles_mod
from .direction import Heading, straight_parts, to_walking
from .events import (
    CONTACT_MIN_FPS,
    DEFAULT_METHOD,
    FINE_CUTOFF_HZ,
    FINE_MAX_FRACTION,
    HEIGHT_CUTOFF_HZ,
    HEIGHT_MAX_FRACTION,
    METHODS,
    detect,
)
from .fallrisk import measures as fall_risk_measures
from .filtering import (
    DEFAULT_CUTOFF_HZ,
    DEFAULT_MAX_GAP_S,
    effective_cutoff,
    lowpass,
    split_segments,
)
from .parameters import (
    SIDES,
    apply_bounds,
    cadence_and_speed,
    drop_close_strikes,
    missing_reasons,
    steps_and_strides,
    summarise,
)
from .trajectories import Trajectories

EVENT_NAMES = tuple(f"{s}_{e}" for s in SIDES for e in ("heel_strike", "toe_off"))
_REQUIRED = ("sacrum", "left_heel", "right_heel", "left_toe", "right_toe")


class PartResult(NamedTuple):
    """One straight part (F frames) of the trial.

    index : 0, 1, ...  start_s, end_s : its time span.  heading : walking frame.
    distance_m : sacrum travel.  time : (F,) s.  coords : role -> (F, 3) filtered walking-frame
    coordinates (forward, left, up), metres.  events : side -> FootEvents.
    """

    index: int
    start_s: float
    end_s: float
    heading: Heading
    distance_m: float
    time: np.ndarray
    coords: dict
    events: dict


class GaitResult(NamedTuple):
    """Everything :func:`analyse` found (times in seconds on the input's clock, metres, degrees).

    method : the event method used (``auto`` resolved).  events : name (``left_heel_strike``
    ...) -> (n,) sorted times.  steps / strides : rows of :class:`~ipf_jax.analysis.gait.parameters.Step`
    / ``Stride`` within the physiological bounds; rejected : the others, and dropped heel
    strikes.  parameters : summary statistics (:func:`~ipf_jax.analysis.gait.parameters.summarise`);
    symmetry : name -> % or None.  lab : cadence and walking speed as gait labs compute them.
    fall_risk : :func:`~ipf_jax.analysis.gait.fallrisk.measures`.  unobservable : parameter -> why the
    cameras cannot measure it.  curves : side -> joint -> (S, 101) degrees over the cycle.
    stand_ins : role -> the role used in its place.  missing : what could not be computed -> why.
    """

    source: str
    method: str
    fps: float
    up_axis: str
    cutoff_hz: float
    parts: list
    events: dict
    steps: list
    strides: list
    parameters: dict
    symmetry: dict
    curves: dict
    stand_ins: dict
    missing: dict
    notes: tuple
    lab: dict
    fall_risk: dict
    rejected: list
    unobservable: dict
    cameras: int | None


def analyse(traj: Trajectories, *, method: str = DEFAULT_METHOD,
            cutoff_hz: float = DEFAULT_CUTOFF_HZ,
            max_gap_s: float = DEFAULT_MAX_GAP_S) -> GaitResult:
    """Gait events and parameters of a walking trial.

    traj : T frames of body points (:func:`ipf_jax.analysis.gait.io.load`). ``method`` is ``auto``
    (default: ``contact`` from :data:`~.events.CONTACT_MIN_FPS` with real heel points, else
    ``zeni``), ``contact``, ``zeni`` or ``velocity``; ``cutoff_hz`` the low-pass cut-off
    (lowered at low frame rates, see :mod:`.filtering`). Raises :class:`IPFError` when the trial
    has no usable walking.
    """
    src = traj.source
    if method not in METHODS:
        raise IPFError(f"unknown event method {method!r} (choose from {', '.join(METHODS)})")
    if not cutoff_hz > 0:
        raise IPFError(f"the cut-off must be positive, got {cutoff_hz}")
    points, stand_ins, notes, missing = _choose_points(traj)
    method, why = _resolve_method(method, traj.fps, stand_ins)
    if why:
        notes.append(why)
    cutoff = effective_cutoff(cutoff_hz, traj.fps)
    fine_cutoff = min(FINE_CUTOFF_HZ, FINE_MAX_FRACTION * traj.fps)
    height_cutoff = min(HEIGHT_CUTOFF_HZ, HEIGHT_MAX_FRACTION * traj.fps)
    notes.append(f"low-pass {cutoff:g} Hz (zero-phase Butterworth)"
                 + (f", lowered from {cutoff_hz:g} Hz for {traj.fps:g} fps" if cutoff < cutoff_hz
                    else "")
                 + (f"; contact cues at {fine_cutoff:g} Hz" if method == "contact" else ""))
    required = tuple(r for r in _REQUIRED if r in points)
    segments, seg_notes = split_segments(traj.time, points, required, fps=traj.fps,
                                         cutoff_hz=cutoff, max_gap_s=max_gap_s)
    notes += seg_notes
    if not segments:
        raise IPFError(f"no stretch of 8 or more frames where {', '.join(required)} are all "
                       "present (all missing, or gaps everywhere)", src)
    parts, errors = [], []
    for seg in segments:
        feet = {s: (seg.points[f"{s}_heel"], seg.points.get(f"{s}_toe")) for s in SIDES}
        try:
            found, part_notes = straight_parts(seg.time, seg.points["sacrum"], feet, traj.up,
                                               source=src)
        except IPFError as e:
            errors.append(e)
            continue
        notes += part_notes
        fine = ({r: lowpass(seg.raw[r], traj.fps, fine_cutoff) for r in required}
                if method == "contact" else {})
        if fine:
            fine.update({f"{s}_height": lowpass(seg.raw[f"{s}_heel"], traj.fps, height_cutoff)
                         for s in SIDES})
        for p in found:
            coords = {r: to_walking(x[p.start:p.stop], p.heading) for r, x in seg.points.items()}
            fine_c = {r: to_walking(x[p.start:p.stop], p.heading) for r, x in fine.items()}
            time = seg.time[p.start:p.stop]
            ev = {}
            for s in SIDES:
                toe = coords.get(f"{s}_toe")
                ev[s] = detect(time, coords["sacrum"][:, 0], coords[f"{s}_heel"][:, 0],
                               toe[:, 0] if toe is not None else None, method=method,
                               fine={"sacrum": fine_c.get("sacrum"),
                                     "heel": fine_c.get(f"{s}_heel"),
                                     "toe": fine_c.get(f"{s}_toe"),
                                     "heel_height": fine_c[f"{s}_height"][:, 2]}
                               if fine_c else None)
            parts.append(PartResult(len(parts), float(time[0]), float(time[-1]), p.heading,
                                    p.distance_m, time, coords, ev))
    if not parts:
        raise errors[0]
    for e in errors:
        notes.append(f"part of the trial skipped: {e.message}")
    return _collect(traj, method, cutoff, parts, points, stand_ins, notes, missing)


def _resolve_method(method: str, fps: float, stand_ins: dict) -> tuple[str, str]:
    if method != "auto":
        return method, ""
    if fps >= CONTACT_MIN_FPS and not any(k.endswith("_heel") for k in stand_ins):
        return "contact", (f"events: contact method ({fps:g} fps, heel and toe points; auto "
                           f"uses it from {CONTACT_MIN_FPS:g} fps)")
    reason = (f"{fps:g} fps" if fps < CONTACT_MIN_FPS else "no heel points")
    return "zeni", (f"events: Zeni method (auto: {reason}; the contact method needs "
                    f"{CONTACT_MIN_FPS:g} fps and heel points)")


def _choose_points(traj: Trajectories) -> tuple[dict, dict, list, dict]:
    """Points the analysis uses, with stand-ins for absent ones (sacrum, heels)."""
    pts = {k: v for k, v in traj.points.items() if np.isfinite(v).any()}
    if not pts:
        raise IPFError("every point is missing on every frame (all missing)", traj.source)
    stand_ins, notes, missing = {}, list(traj.notes), {}
    if "sacrum" not in pts:
        if "pelvis" in pts:
            pts["sacrum"] = pts["pelvis"]
            stand_ins["sacrum"] = "pelvis"
            notes.append("no sacrum point with data: the pelvis reference stands in for it")
        elif "left_hip" in pts and "right_hip" in pts:
            pts["sacrum"] = 0.5 * (pts["left_hip"] + pts["right_hip"])
            stand_ins["sacrum"] = "mid-hips"
            notes.append("no sacrum point: the midpoint of the hips stands in for it")
        else:
            raise IPFError("no sacrum point (nor a pelvis reference or both hips) to measure the "
                           "feet against", traj.source)
    pts.pop("pelvis", None)
    for side in SIDES:
        heel = f"{side}_heel"
        if heel not in pts:
            if f"{side}_ankle" not in pts:
                raise IPFError(f"no {side} heel or ankle point: cannot find {side} heel strikes",
                               traj.source)
            pts[heel] = pts[f"{side}_ankle"]
            stand_ins[heel] = f"{side}_ankle"
            notes.append(f"no {side} heel point: the {side} ankle stands in for it (heel "
                         "strikes from the ankle; ankle angle not computed)")
        if f"{side}_toe" not in pts:
            missing[f"events.{side}_toe_off"] = f"no {side} toe point"
    return pts, stand_ins, notes, missing


def _unobservable(traj: Trajectories) -> dict:
    if traj.cameras == 1:
        return {"step_width_m": "one camera (run.json) does not measure depth, and step width "
                                "lies across a side-on camera's line of sight"}
    return {}


def _collect(traj, method, cutoff, parts, points, stand_ins, notes, missing) -> GaitResult:
    """Merge the parts: events, steps, strides, statistics, cycle curves, missing reasons."""
    unobservable = _unobservable(traj)
    events = {name: [] for name in EVENT_NAMES}
    steps, strides, rejected, lab_parts = [], [], [], []
    curves = {s: {} for s in SIDES}
    for i, part in enumerate(parts):
        ev, dropped = drop_close_strikes(part.events, part.start_s, part.end_s)
        rejected += [r._replace(part=part.index) for r in dropped]
        part = part._replace(events=ev)
        parts[i] = part
        for s in SIDES:
            events[f"{s}_heel_strike"] += list(ev[s].heel_strike)
            events[f"{s}_toe_off"] += list(ev[s].toe_off)
        heels = {s: part.coords[f"{s}_heel"] for s in SIDES}
        st, sd = steps_and_strides(part.index, part.time, heels, ev, mode=part.heading.mode)
        st, sd, rej = apply_bounds(st, sd, unobservable=tuple(unobservable))
        steps += st
        strides += sd
        rejected += rej
        strikes = sorted((t, s) for s in SIDES for t in ev[s].heel_strike)
        sac = part.coords["sacrum"][:, 0]
        lab_parts.append((part.index, part.heading.mode, strikes,
                          lambda t, tt=part.time, x=sac: float(np.interp(t, tt, x))))
        for s in SIDES:
            ang, why = angles_mod.joint_angles(part.coords, s,
                                               has_heel=f"{s}_heel" not in stand_ins)
            spans = [(r.start_s, r.end_s) for r in sd if r.side == s]
            for joint, series in ang.items():
                curves[s].setdefault(joint, []).append(
                    angles_mod.cycle_curves(part.time, series, spans))
            for joint, reason in why.items():
                missing[f"curves.{s}.{joint}"] = reason
    curves = {s: {j: np.concatenate(c) for j, c in by.items()} for s, by in curves.items()}
    events = {k: np.array(sorted(v)) for k, v in events.items()}
    params, symmetry = summarise(steps, strides)
    lab = cadence_and_speed(lab_parts, rejected)
    params["cadence_steps_per_min"]["all"] = {"mean": lab["cadence_steps_per_min"], "sd": None,
                                              "cv_pct": None, "n": lab["steps"]}
    for name, why in unobservable.items():
        for side in (*SIDES, "all"):
            params[name][side] = {"mean": None, "sd": None, "cv_pct": None, "n": 0}
        missing[name] = f"not observable: {why}"
    counts = {s: (len(events[f"{s}_heel_strike"]), len(events[f"{s}_toe_off"])) for s in SIDES}
    has_toe = {s: f"{s}_toe" in points for s in SIDES}
    for key, why in missing_reasons(params, symmetry, counts=counts, has_toe=has_toe).items():
        if key.split(".")[0] not in unobservable:
            missing[key] = why
    for name, times in events.items():
        if times.size == 0 and f"events.{name}" not in missing:
            missing[f"events.{name}"] = "none found in the straight walking parts"
    for s in SIDES:
        for joint in angles_mod.JOINTS:
            if f"curves.{s}.{joint}" not in missing and curves[s].get(joint, np.empty(0)).size == 0:
                missing[f"curves.{s}.{joint}"] = f"no complete {s} stride"
    if rejected:
        notes.append(f"{len(rejected)} steps, strides or heel strikes outside the physiological "
                     "bounds left out (see 'rejected')")
    fall = fall_risk_measures(params, symmetry, lab, unobservable=unobservable)
    return GaitResult(traj.source, method, traj.fps, traj.up_axis, cutoff, parts, events, steps,
                      strides, params, symmetry, curves, stand_ins, dict(sorted(missing.items())),
                      tuple(notes), lab, fall, rejected, unobservable, traj.cameras)
