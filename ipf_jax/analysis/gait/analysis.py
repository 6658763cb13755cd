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
from .events import DEFAULT_METHOD, METHODS, detect
from .filtering import (
    DEFAULT_CUTOFF_HZ,
    DEFAULT_MAX_GAP_S,
    effective_cutoff,
    split_segments,
)
from .io import Trajectories
from .parameters import SIDES, missing_reasons, steps_and_strides, summarise

EVENT_NAMES = tuple(f"{s}_{e}" for s in SIDES for e in ("heel_strike", "toe_off"))


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

    events : name (``left_heel_strike`` ...) -> (n,) sorted times.  steps / strides : rows of
    :class:`~ipf_jax.analysis.gait.parameters.Step` / ``Stride``.  parameters : summary statistics (see
    :func:`~ipf_jax.analysis.gait.parameters.summarise`); symmetry : name -> % or None.
    curves : side -> joint -> (S, 101) degrees over the cycle.  stand_ins : role -> the role used
    in its place (``left_heel`` -> ``left_ankle``).  missing : what could not be computed -> why.
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


def analyse(traj: Trajectories, *, method: str = DEFAULT_METHOD,
            cutoff_hz: float = DEFAULT_CUTOFF_HZ,
            max_gap_s: float = DEFAULT_MAX_GAP_S) -> GaitResult:
    """Gait events and parameters of a walking trial.

    traj : T frames of body points (:func:`ipf_jax.analysis.gait.io.load`). ``method`` is ``zeni``
    (default) or ``velocity``; ``cutoff_hz`` the low-pass cut-off (lowered at low frame rates,
    see :mod:`.filtering`). Raises :class:`IPFError` when the trial has no usable walking.
    """
    src = traj.source
    if method not in METHODS:
        raise IPFError(f"unknown event method {method!r} (choose from {', '.join(METHODS)})")
    if not cutoff_hz > 0:
        raise IPFError(f"the cut-off must be positive, got {cutoff_hz}")
    points, stand_ins, notes, missing = _choose_points(traj)
    cutoff = effective_cutoff(cutoff_hz, traj.fps)
    notes.append(f"low-pass {cutoff:g} Hz (zero-phase Butterworth)"
                 + (f", lowered from {cutoff_hz:g} Hz for {traj.fps:g} fps" if cutoff < cutoff_hz
                    else ""))
    required = tuple(r for r in ("sacrum", "left_heel", "right_heel", "left_toe", "right_toe")
                     if r in points)
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
        for p in found:
            coords = {r: to_walking(x[p.start:p.stop], p.heading) for r, x in seg.points.items()}
            time = seg.time[p.start:p.stop]
            ev = {s: detect(time, coords["sacrum"][:, 0], coords[f"{s}_heel"][:, 0],
                            coords[f"{s}_toe"][:, 0] if f"{s}_toe" in coords else None,
                            method=method) for s in SIDES}
            parts.append(PartResult(len(parts), float(time[0]), float(time[-1]), p.heading,
                                    p.distance_m, time, coords, ev))
    if not parts:
        raise errors[0]
    for e in errors:
        notes.append(f"part of the trial skipped: {e.message}")
    return _collect(traj, method, cutoff, parts, points, stand_ins, notes, missing)


def _choose_points(traj: Trajectories) -> tuple[dict, dict, list, dict]:
    """Points the analysis uses, with stand-ins for absent ones (sacrum, heels)."""
    pts = dict(traj.points)
    stand_ins, notes, missing = {}, list(traj.notes), {}
    if "sacrum" not in pts:
        if "left_hip" in pts and "right_hip" in pts:
            pts["sacrum"] = 0.5 * (pts["left_hip"] + pts["right_hip"])
            stand_ins["sacrum"] = "mid-hips"
            notes.append("no sacrum point: the midpoint of the hips stands in for it")
        else:
            raise IPFError("no sacrum point (nor both hips) to measure the feet against",
                           traj.source)
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


def _collect(traj, method, cutoff, parts, points, stand_ins, notes, missing) -> GaitResult:
    """Merge the parts: events, steps, strides, statistics, cycle curves, missing reasons."""
    events = {name: [] for name in EVENT_NAMES}
    steps, strides = [], []
    curves = {s: {} for s in SIDES}
    for part in parts:
        for s in SIDES:
            events[f"{s}_heel_strike"] += list(part.events[s].heel_strike)
            events[f"{s}_toe_off"] += list(part.events[s].toe_off)
        heels = {s: part.coords[f"{s}_heel"] for s in SIDES}
        st, sd = steps_and_strides(part.index, part.time, heels, part.events,
                                   mode=part.heading.mode)
        steps += st
        strides += sd
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
    counts = {s: (len(events[f"{s}_heel_strike"]), len(events[f"{s}_toe_off"])) for s in SIDES}
    has_toe = {s: f"{s}_toe" in points for s in SIDES}
    missing.update(missing_reasons(params, symmetry, counts=counts, has_toe=has_toe))
    for name, times in events.items():
        if times.size == 0 and f"events.{name}" not in missing:
            missing[f"events.{name}"] = "none found in the straight walking parts"
    for s in SIDES:
        for joint in angles_mod.JOINTS:
            if f"curves.{s}.{joint}" not in missing and curves[s].get(joint, np.empty(0)).size == 0:
                missing[f"curves.{s}.{joint}"] = f"no complete {s} stride"
    return GaitResult(traj.source, method, traj.fps, traj.up_axis, cutoff, parts, events, steps,
                      strides, params, symmetry, curves, stand_ins, dict(sorted(missing.items())),
                      tuple(notes))
