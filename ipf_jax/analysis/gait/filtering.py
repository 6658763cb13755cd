"""Gap handling and zero-phase low-pass filtering of trajectories before event detection.

Filter: a second-order Butterworth low-pass run forward and backward (``scipy.signal.sosfiltfilt``),
i.e. fourth order overall with no phase lag, the usual choice for gait kinematics (Winter). The
cut-off is lowered to at most a quarter of the frame rate: near Nyquist the filter would leave the
tracker's frame-to-frame jitter in, and that jitter moves the extrema the events are read from.
The default cut-off is 5 Hz, which is that ceiling at the tracker's 20 Hz; using it for marker
data too keeps events from the tracker and from a reference system filtered alike (the walking
signals used here have little power above 5 Hz). On the Rajagopal trial, 6 Hz moves Zeni heel
strikes 2 ms earlier (see ``docs/gait.md``).

Gaps: a point missing for at most ``max_gap_s`` (default 0.1 s, at least one frame) is linearly
interpolated; a longer gap in a required point splits the trial into segments analysed separately,
since bridging a whole step would invent a foot contact. So does a jump in the clock (a time step
longer than three median steps: frames skipped, or a damaged time column).
"""
from __future__ import annotations

from itertools import pairwise
from typing import NamedTuple

import numpy as np
from scipy.signal import butter, sosfiltfilt

DEFAULT_CUTOFF_HZ = 5.0
#: Cut-off never above this fraction of the frame rate (half of Nyquist).
MAX_CUTOFF_FRACTION = 0.25
DEFAULT_MAX_GAP_S = 0.1
_ORDER = 2  # per pass; two passes make the fourth-order zero-lag filter
#: A time step longer than this many median steps splits the trial (no velocity across it).
MAX_CLOCK_JUMP = 3.0


class DataSegment(NamedTuple):
    """A stretch of frames where every required point is present (after short-gap filling).

    start, stop : frame indices into the trial, ``stop`` exclusive (F = stop - start frames).
    time : (F,) seconds.  points : role -> (F, 3) metres, gap-filled and low-pass filtered.
    filled : number of frames interpolated in required points.
    raw : role -> (F, 3) gap-filled but unfiltered (for event cues that need a higher cut-off).
    """

    start: int
    stop: int
    time: np.ndarray
    points: dict
    filled: int
    raw: dict


def effective_cutoff(cutoff_hz: float, fps: float) -> float:
    """The cut-off actually used: ``min(cutoff_hz, MAX_CUTOFF_FRACTION * fps)``."""
    return float(min(cutoff_hz, MAX_CUTOFF_FRACTION * fps))


def lowpass(x: np.ndarray, fps: float, cutoff_hz: float) -> np.ndarray:
    """Zero-phase Butterworth low-pass along axis 0; NaN runs are left NaN.

    x : (T, ...) samples at ``fps``. Each finite run is filtered on its own (a run too short to
    pad is returned as is). Returns an array of the same shape.
    """
    x = np.asarray(x, dtype=float)
    sos = butter(_ORDER, cutoff_hz / (0.5 * fps), output="sos")
    out = x.copy()
    finite = np.all(np.isfinite(x.reshape(len(x), -1)), axis=1)
    for a, b in true_runs(finite):
        n = b - a
        if n < 4:
            continue
        # sosfiltfilt's default padding (9 samples here) needs longer input; pad what we have
        out[a:b] = sosfiltfilt(sos, x[a:b], axis=0, padlen=min(9, n - 1))
    return out


def fill_short_gaps(x: np.ndarray, max_gap: int) -> tuple[np.ndarray, int]:
    """Linearly interpolate interior NaN gaps of at most ``max_gap`` frames.

    x : (T, 3). Returns the filled copy and the number of frames filled. Gaps touching either end
    are left (extrapolating a foot is guessing).
    """
    out = np.array(x, dtype=float)
    ok = np.all(np.isfinite(out), axis=1)
    filled = 0
    idx = np.flatnonzero(ok)
    for a, b in true_runs(~ok):
        if a == 0 or b == len(ok) or b - a > max_gap:
            continue
        for c in range(out.shape[1]):
            out[a:b, c] = np.interp(np.arange(a, b), idx, out[idx, c])
        filled += b - a
    return out, filled


def split_segments(time: np.ndarray, points: dict, required: tuple, *, fps: float,
                   cutoff_hz: float, max_gap_s: float = DEFAULT_MAX_GAP_S,
                   min_frames: int = 8) -> tuple[list, list]:
    """Fill short gaps, cut at long ones, filter each piece.

    time : (T,).  points : role -> (T, 3).  required : roles that must be present in a frame.
    Returns (segments, notes): :class:`DataSegment` list in time order (pieces shorter than
    ``min_frames`` dropped) and remarks on what was filled or dropped.
    """
    max_gap = max(1, int(round(max_gap_s * fps)))
    filled, count = {}, 0
    for role, x in points.items():
        filled[role], n = fill_short_gaps(x, max_gap)
        if role in required:
            count += n
    ok = np.ones(len(time), dtype=bool)
    for role in required:
        ok &= np.all(np.isfinite(filled[role]), axis=1)
    segments, notes = [], []
    # a jump in the clock (frames skipped, or a damaged time column) also ends a segment
    dt = np.diff(time)
    jumps = np.flatnonzero(dt > MAX_CLOCK_JUMP * np.median(dt))
    if jumps.size:
        notes.append(f"{jumps.size} jumps in the clock (longer than {MAX_CLOCK_JUMP:g} frame "
                     "intervals) split the trial")
    run_id = np.concatenate([[0], np.cumsum(dt > MAX_CLOCK_JUMP * np.median(dt))])
    if count:
        notes.append(f"{count} missing frames (gaps up to {max_gap} frames) interpolated "
                     "in required points")
    runs = [(a + c, a + d) for a, b in true_runs(ok)
            for c, d in _pieces(run_id[a:b])]
    for a, b in runs:
        if b - a < min_frames:
            notes.append(f"frames {a}-{b - 1} dropped: only {b - a} complete frames")
            continue
        seg_pts = {role: lowpass(x[a:b], fps, cutoff_hz) for role, x in filled.items()}
        n_filled = sum(int(np.sum(~np.all(np.isfinite(points[r][a:b]), axis=1)))
                       for r in required)
        segments.append(DataSegment(a, b, time[a:b], seg_pts, n_filled,
                                    {role: x[a:b] for role, x in filled.items()}))
    if len(segments) > 1:
        notes.append(f"gaps longer than {max_gap} frames split the trial into {len(segments)} "
                     "parts analysed separately")
    return segments, notes


def _pieces(ids: np.ndarray) -> list:
    """(start, stop) of each run of equal values in ``ids`` (F,)."""
    cuts = np.flatnonzero(np.diff(ids)) + 1
    edges = np.concatenate([[0], cuts, [len(ids)]])
    return list(pairwise(edges))


def true_runs(mask: np.ndarray) -> list:
    """(start, stop) of each run of True in a 1-D boolean mask."""
    m = np.concatenate([[False], np.asarray(mask, dtype=bool), [False]])
    d = np.diff(m.astype(np.int8))
    return list(zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1)))
