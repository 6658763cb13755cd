"""Heel strikes and toe-offs of one foot from its coordinates in the walking frame.

Methods share one signature ``(time, sacrum, heel, toe) -> FootEvents`` (all (F,) forward
coordinates in metres of one straight part, already low-pass filtered; ``contact`` also reads
finer-filtered 3-D signals):

``contact`` (default for marker data: ``auto`` picks it from 50 fps with real heel points). Heel
strike: for each Zeni heel strike (below) three cues, and their median: (1) the Zeni time, which
comes early (the heel is furthest ahead before it lands: -30 to -65 ms on the gait_trials); (2)
the first time from 0.05 s before it to 0.25 s after it that the heel's sagittal speed (forward
velocity relative to the foot's stance level, with its vertical velocity) falls below 0.26 x the
walking speed; (3) the first local minimum of heel height within 10 mm of the lowest in that
window, which comes late when the heel sinks into the shoe after contact. The median is the
speed cue unless it leaves the bracket the other two make (a heel gliding at contact, or one that
stops before it). Toe-off: the toe's forward ground velocity rises above 0.8 x the walking speed
before its swing peak. Cues are read from signals filtered at 15 Hz (height: 20 Hz), at most a
quarter (a third) of the frame rate. On the six gait_trials and the Rajagopal walk every heel
strike is within max(2 frames, 20 ms) of the force plates and every toe-off within 27 ms, but the
heel-strike margin is thin (the worst at 0.98 of its tolerance): the labs' plates disagree with
each other by more than any kinematic cue can absorb (``docs/gait.md``).

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

METHODS = ("auto", "contact", "zeni", "velocity")
DEFAULT_METHOD = "auto"
#: ``auto`` uses ``contact`` from this frame rate up (with real heel points), else ``zeni``.
CONTACT_MIN_FPS = 50.0
#: Cut-off (Hz) of the fine signals the ``contact`` cues are read from (at most fps / 4).
FINE_CUTOFF_HZ = 15.0
FINE_MAX_FRACTION = 0.25
#: ... and the heel-height cue at this cut-off (at most a third of the frame rate).
HEIGHT_CUTOFF_HZ = 20.0
HEIGHT_MAX_FRACTION = 1.0 / 3.0
#: contact cues: heel sagittal speed below this fraction of the walking speed ...
HS_SPEED_V = 0.26
#: ... searched from 0.05 s before the Zeni heel strike to 0.25 s after it; the first local
#: minimum of heel height within 10 mm of the window's lowest.
HS_WINDOW_S = (0.05, 0.25)
HS_LOW_M = 0.010
#: contact toe-off: the toe's forward ground velocity rises above this fraction of the speed.
TO_SPEED_V = 0.8
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
           method: str = "zeni", fine: dict | None = None) -> FootEvents:
    """Events of one foot by ``method`` (``contact``, ``zeni`` or ``velocity``); see module docs.

    time : (F,) s.  sacrum, heel : (F,) forward coordinate, m.  toe : (F,) or None (no toe-offs).
    fine : for ``contact``, ``{"sacrum", "heel", "toe"}`` -> (F, 3) walking-frame coordinates
    (forward, left, up) filtered at :data:`FINE_CUTOFF_HZ` (``toe`` may be None).
    """
    if method == "contact":
        if fine is None:
            raise ValueError("the contact method needs the fine signals")
        hs = _contact_strikes(time, sacrum, heel, fine)
        to = (_crossings(time, fine["toe"][:, 0], _walking_speed(time, fine["sacrum"][:, 0],
                                                                 fine["heel"][:, 0]),
                         TO_SPEED_V, after_peak=False)
              if fine.get("toe") is not None else np.empty(0))
    elif method == "zeni":
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


def _contact_strikes(time: np.ndarray, sacrum: np.ndarray, heel: np.ndarray,
                     fine: dict) -> np.ndarray:
    """Heel strikes as the median of three cues per Zeni heel strike (see module docs)."""
    zeni = _extrema_times(time, heel - sacrum)
    h = fine["heel"]
    speed = _walking_speed(time, fine["sacrum"][:, 0], h[:, 0])
    vx = np.gradient(h[:, 0], time)
    vx = vx - _stance_level(vx)
    sp = np.hypot(vx, np.gradient(h[:, 2], time))
    z = fine["heel_height"] if fine.get("heel_height") is not None else h[:, 2]
    out = []
    for tz in zeni:
        a = max(1, int(np.searchsorted(time, tz - HS_WINDOW_S[0])))
        b = min(len(time) - 2, int(np.searchsorted(time, tz + HS_WINDOW_S[1])))
        if b - a < 2:
            continue
        t_speed = np.nan
        thr = HS_SPEED_V * speed
        for k in range(a, b):
            if sp[k] >= thr > sp[k + 1]:
                t_speed = _time_at(time, k + (sp[k] - thr) / (sp[k] - sp[k + 1]))
                break
        if not np.isfinite(t_speed) and tz + HS_WINDOW_S[1] > time[-1]:
            continue  # the record ends before the heel has slowed: not confirmed
        low = z[a:b + 1].min()
        t_low = np.nan
        for k in range(a + 1, b):
            if z[k] - low < HS_LOW_M and z[k] <= z[k - 1] and z[k] <= z[k + 1]:
                t_low = _time_at(time, refine_peak(-z, k))
                break
        cues = np.array([tz, t_speed, t_low])
        out.append(float(np.nanmedian(cues)))
    return np.array(out)


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
