"""Heel strikes and toe-offs of one foot from its forward (walking-direction) coordinates.

Two methods, one signature ``(time, sacrum, heel, toe) -> FootEvents`` (all (F,) forward
coordinates in metres of one straight part, already low-pass filtered):

``zeni`` (default; Zeni, Richards & Higginson 2008, Gait Posture 27:710): heel strike is a maximum
of heel minus sacrum, toe-off a minimum of toe minus sacrum. It needs no threshold and works
overground and on a treadmill alike. The extremum is refined below a frame by a parabola through
the three samples around it, which matters at the tracker's 20 Hz (50 ms frames).

``velocity``: foot velocity thresholds in the ground frame. Forward velocities are taken relative
to the foot's stance level (the median of its lower half, about 0 overground and minus the belt
speed on a treadmill) and compared with the walking speed V (sacrum speed over the ground). Heel
strike: after a swing peak (> 1.5 V) the heel's velocity falls below 0.5 V. Toe-off: before a
swing peak the toe's velocity rises above V (the toe starts to outrun the body). Crossings are
linearly interpolated. Velocities need a real heel point and a high frame rate: with the ankle
standing in for the heel, or at 20 Hz, heel strikes come 15-30 ms late (``docs/gait.md``).

Extrema and swing peaks of one foot closer than 0.5 s are merged (a stride lasts 0.8 s even at
a brisk 150 steps/min). Extrema too shallow (less than a quarter of the signal's 5-95 % range)
are rejected as noise.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy.signal import find_peaks

METHODS = ("zeni", "velocity")
DEFAULT_METHOD = "zeni"
MIN_INTERVAL_S = 0.5
MIN_DEPTH_FRACTION = 0.25
SWING_PEAK_V = 1.5
HEEL_STRIKE_V = 0.5
TOE_OFF_V = 1.0


class FootEvents(NamedTuple):
    """Event times of one foot, seconds, increasing. heel_strike : (H,).  toe_off : (O,)."""

    heel_strike: np.ndarray
    toe_off: np.ndarray


def detect(time: np.ndarray, sacrum: np.ndarray, heel: np.ndarray, toe: np.ndarray | None, *,
           method: str = DEFAULT_METHOD) -> FootEvents:
    """Events of one foot by ``method`` (``zeni`` or ``velocity``); see the module docs.

    time : (F,) s.  sacrum, heel : (F,) forward coordinate, m.  toe : (F,) or None (no toe-offs).
    """
    if method == "zeni":
        hs = _extrema_times(time, heel - sacrum)
        to = _extrema_times(time, -(toe - sacrum)) if toe is not None else np.empty(0)
    elif method == "velocity":
        speed = _walking_speed(time, sacrum, heel)
        hs = _crossings(time, heel, speed, HEEL_STRIKE_V, after_peak=True)
        to = (_crossings(time, toe, speed, TOE_OFF_V, after_peak=False) if toe is not None
              else np.empty(0))
    else:
        raise ValueError(f"unknown event method {method!r} (choose from {METHODS})")
    return FootEvents(np.asarray(hs, dtype=float), np.asarray(to, dtype=float))


def refine_peak(y: np.ndarray, i: int) -> float:
    """Sub-sample index of the maximum near ``i`` by a parabola through ``y[i-1:i+2]``.

    The vertex offset is clipped to +-0.5 sample (beyond that the neighbour was the maximum).
    """
    a, b, c = y[i - 1], y[i], y[i + 1]
    den = a - 2.0 * b + c
    if den >= 0:  # flat or not a maximum: keep the sample
        return float(i)
    return float(i + np.clip(0.5 * (a - c) / den, -0.5, 0.5))


def _time_at(time: np.ndarray, index: float) -> float:
    return float(np.interp(index, np.arange(len(time)), time))


def _depth_threshold(y: np.ndarray) -> float:
    lo, hi = np.percentile(y, [5, 95])
    return MIN_DEPTH_FRACTION * float(hi - lo)


def _extrema_times(time: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Times of the maxima of ``y`` (F,) that stand out, refined below a frame.

    A maximum must fall by the depth threshold on both sides within 0.5 s, except on a side
    where the record ends sooner: a contact just inside the trial has no room for its fall.
    """
    fps = (len(time) - 1) / (time[-1] - time[0])
    w = max(2, int(round(MIN_INTERVAL_S * fps)))
    peaks, _ = find_peaks(y, distance=w)
    need = _depth_threshold(y)
    out = []
    for i in peaks:
        left, right = y[max(0, i - w):i], y[i + 1:i + 1 + w]
        drop_l, drop_r = y[i] - left.min(), y[i] - right.min()
        ok_l = drop_l >= need or (i - w < 0 and drop_r >= need)
        ok_r = drop_r >= need or (i + w >= len(y) and drop_l >= need)
        if ok_l and ok_r:
            out.append(_time_at(time, refine_peak(y, i)))
    return np.array(out)


def _walking_speed(time: np.ndarray, sacrum: np.ndarray, heel: np.ndarray) -> float:
    """Sacrum speed over the ground: mean sacrum velocity minus the heel's stance velocity."""
    v_sacrum = np.gradient(sacrum, time)
    return float(np.mean(v_sacrum) - _stance_level(np.gradient(heel, time)))


def _stance_level(v: np.ndarray) -> float:
    """Velocity of a foot while it stands: median of the lower half of its forward velocity."""
    return float(np.median(v[v <= np.median(v)]))


def _crossings(time: np.ndarray, x: np.ndarray, speed: float, level: float, *,
               after_peak: bool) -> np.ndarray:
    """Where the foot's ground velocity crosses ``level * speed`` next to its swing peaks.

    after_peak=True: first downward crossing after each peak (heel strike); False: last upward
    crossing before it (toe-off). Peaks at the record's ends count, crossings must be inside.
    """
    fps = (len(time) - 1) / (time[-1] - time[0])
    v = np.gradient(x, time)
    g = v - _stance_level(v)
    padded = np.concatenate([[-np.inf], g, [-np.inf]])  # lets a swing cut by an end be a peak
    peaks, _ = find_peaks(padded, height=SWING_PEAK_V * speed,
                          distance=max(1, int(round(MIN_INTERVAL_S * fps))))
    peaks = peaks - 1
    thr = level * speed
    out = []
    for p in peaks:
        if after_peak:
            below = np.flatnonzero(g[p:] < thr)
            j = p + below[0] if below.size else None
            k = j - 1 if j is not None else None
        else:
            below = np.flatnonzero(g[:p + 1] < thr)
            k = below[-1] if below.size else None
            j = k + 1 if k is not None else None
        if k is None or k < 0 or j >= len(g):
            continue
        frac = (thr - g[k]) / (g[j] - g[k])
        out.append(_time_at(time, k + frac))
    return np.array(sorted(set(out)))
