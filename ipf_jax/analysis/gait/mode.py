"""Overground or treadmill: decided from the data, with a margin.

Overground the standing foot is still and the pelvis travels at the walking speed; on a treadmill
the pelvis stays put and the standing foot travels backwards at the belt speed. So the evidence
is the ratio

    r = u_pelvis / (u_pelvis + u_stance)

of the pelvis's horizontal speed (median over the trial, velocity over a 1 s window) to the sum of
it and the standing foot's speed (the 20th percentile of each heel's horizontal speed: the
slowest fifth of the frames is mid-stance; both feet averaged). r is about 1 overground and
about 0 on a treadmill: **overground when r >= 0.7, treadmill when r <= 0.3**. In between, or in
a clip too short to hold a stance phase of each foot (under :data:`MIN_DECIDE_S`), the feet
cannot decide; the trial is then analysed as overground when the pelvis moves (faster than
:data:`MIN_PELVIS_SPEED`), else as treadmill walking, and the note says which rule decided.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

OVERGROUND_RATIO = 0.7
TREADMILL_RATIO = 0.3
MIN_DECIDE_S = 1.0          # about one stride: each foot has stood once
MIN_PELVIS_SPEED = 0.15     # m/s
STANCE_PERCENTILE = 20.0
SMOOTH_S = 1.0


class Mode(NamedTuple):
    """mode : ``overground`` or ``treadmill``.  ratio : r above (None when not computed).
    pelvis_speed, stance_speed : m/s.  decided_by : ``feet`` or ``pelvis`` (see module docs).
    note : the sentence for gait.json's notes."""

    mode: str
    ratio: float | None
    pelvis_speed: float
    stance_speed: float | None
    decided_by: str
    note: str


def smoothed_velocity(time: np.ndarray, path: np.ndarray, window_s: float = SMOOTH_S
                      ) -> np.ndarray:
    """(F, k) central difference of ``path`` (F, k) over ``window_s`` (shrinking at the ends)."""
    n = len(time)
    fps = (n - 1) / (time[-1] - time[0])
    half = max(1, round(window_s * fps) // 2)
    lo = np.clip(np.arange(n) - half, 0, n - 1)
    hi = np.clip(np.arange(n) + half, 0, n - 1)
    return (path[hi] - path[lo]) / (time[hi] - time[lo])[:, None]


def decide(time: np.ndarray, pelvis_h: np.ndarray, heels_h: list) -> Mode:
    """Mode of one gap-free stretch. pelvis_h : (F, 2) horizontal pelvis path, m; heels_h :
    list of (F, 2) horizontal heel paths (one per foot)."""
    duration = float(time[-1] - time[0])
    pelvis = float(np.median(np.linalg.norm(smoothed_velocity(time, pelvis_h), axis=1)))
    stance = None
    if heels_h and duration >= MIN_DECIDE_S:
        speeds = [np.percentile(np.linalg.norm(np.gradient(h, time, axis=0), axis=1),
                                STANCE_PERCENTILE) for h in heels_h]
        stance = float(np.mean(speeds))
    if stance is not None:
        r = pelvis / (pelvis + stance) if pelvis + stance > 0 else 0.0
        facts = (f"the pelvis moves {pelvis:.2f} m/s, the standing foot {stance:.2f} m/s "
                 f"(ratio {r:.2f}; overground >= {OVERGROUND_RATIO}, treadmill <= "
                 f"{TREADMILL_RATIO})")
        if r >= OVERGROUND_RATIO:
            return Mode("overground", r, pelvis, stance, "feet", f"overground walking: {facts}")
        if r <= TREADMILL_RATIO:
            return Mode("treadmill", r, pelvis, stance, "feet", f"treadmill walking: {facts}")
        why = f"{facts}: between the margins"
    else:
        r = None
        why = (f"{duration:.2f} s is too short to compare the feet with the pelvis (needs "
               f"{MIN_DECIDE_S:g} s)")
    if pelvis > MIN_PELVIS_SPEED:
        return Mode("overground", r, pelvis, stance, "pelvis",
                    f"analysed as overground walking: {why}, and the pelvis moves "
                    f"{pelvis:.2f} m/s (> {MIN_PELVIS_SPEED} m/s)")
    return Mode("treadmill", r, pelvis, stance, "pelvis",
                f"analysed as treadmill walking: {why}, and the pelvis moves only "
                f"{pelvis:.2f} m/s (<= {MIN_PELVIS_SPEED} m/s)")
