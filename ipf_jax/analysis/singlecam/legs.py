"""Left/right leg swaps: what one camera cannot tell apart (docs/single_camera.md).

Seen from one side the two legs have the same silhouette, so a tracker may exchange them. In the
sagittal plane (walking direction x up, relative to the sacrum) this shows in two ways. A *jump*
(e.g. at re-initialisation): the labelled legs fit the constant-velocity prediction from the
previous two frames worse than the exchanged labels do. A *bounce* where the legs cross: the
model's ankles come together and part again on the sides they came from, where walking legs pass
each other, so two successive steps have the same sign of left-minus-right ankle.
:func:`detect_leg_swaps` finds both; the correction exchanges the legs' DOFs (or points) on every
frame after an odd number of swaps. Which leg is really the left one stays unknown (the first
frame's labels are kept).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy.signal import find_peaks

from ...body.model import DOF_INDEX, POINT_INDEX
from ...errors import require

LEG_POINTS = ("knee", "ankle", "heel", "toe")
LEG_DOFS = ("hip_flexion", "hip_abduction", "hip_rotation", "knee_flexion", "ankle_dorsiflexion",
            "ankle_inversion")
MIN_GAIN_M = 0.05  # a swap must fit better by this much (sum over both legs of the mean point
# distance): above the frame-to-frame jitter of a tracked ankle, below the smallest real swap
RATIO = 0.5  # ...and at least twice as well
MEETING_M = 0.2  # the ankles' separation along the walk must dip by this much to count as a
# meeting (a crossing or a bounce): well above a tracked ankle's jitter, below the separation of
# even short steps (0.4 m and more between meetings)


class LegSwaps(NamedTuple):
    """swaps : (K,) row indices t where the labels are exchanged between rows t-1 and t.
    parity : (T,) bool, rows whose labels are exchanged relative to the first row.
    gain_m : (T,) float, how much better the exchanged labels fit (m); nan where not evaluated."""

    swaps: np.ndarray
    parity: np.ndarray
    gain_m: np.ndarray


def sagittal_legs(joints: np.ndarray, up: np.ndarray) -> np.ndarray:
    """(T, J, 3) joints -> (T, 2, P, 2): left/right knee, ankle, heel, toe relative to the sacrum,
    as (forward, up) coordinates. Forward is the sacrum's net horizontal displacement, or, when it
    barely moves (treadmill), the main horizontal axis of the ankles' motion."""
    joints = np.asarray(joints, float)
    sacrum = joints[:, POINT_INDEX["sacrum"]]
    ok = np.all(np.isfinite(joints), axis=(1, 2))
    require(ok.sum() >= 2, "fewer than two tracked frames")

    def horizontal(v):
        return v - np.outer(v @ up, up) if v.ndim == 2 else v - up * (v @ up)

    net = horizontal(sacrum[ok][-1] - sacrum[ok][0])
    if np.linalg.norm(net) < 0.2:
        rel = horizontal(joints[ok, POINT_INDEX["left_ankle"]] - sacrum[ok])
        net = np.linalg.svd(rel - rel.mean(0))[2][0]
    forward = net / np.linalg.norm(net)
    idx = [[POINT_INDEX[f"{s}_{p}"] for p in LEG_POINTS] for s in ("left", "right")]
    rel = joints[:, idx] - sacrum[:, None, None]  # (T, 2, P, 3)
    return np.stack([rel @ forward, rel @ up], axis=-1)


def _jumps(legs: np.ndarray, frames: np.ndarray, min_gain_m: float, ratio: float):
    """Rows where the exchanged labels continue the previous two rows better (see module doc).
    Returns (rows, (T,) gain in metres)."""
    gain = np.full(len(legs), np.nan)
    rows, history = [], []  # history: (frame, corrected legs) of the last two tracked rows
    flip = False
    for t, x in enumerate(legs):
        if not np.all(np.isfinite(x)):
            continue
        x = x[::-1] if flip else x
        if history:
            f1, x1 = history[-1]
            pred = x1
            if len(history) == 2:
                f0, x0 = history[0]
                pred = x1 + (x1 - x0) * (frames[t] - f1) / (f1 - f0)
            same = np.linalg.norm(x - pred, axis=-1).mean(-1).sum()
            other = np.linalg.norm(x[::-1] - pred, axis=-1).mean(-1).sum()
            gain[t] = same - other
            if same - other > min_gain_m and other < ratio * same:
                flip = not flip
                x = x[::-1]
                rows.append(t)
        history = (history + [(frames[t], x)])[-2:]
    return rows, gain


def _bounces(d: np.ndarray, meeting_m: float) -> list[int]:
    """Rows where the ankles meet and part again on the sides they came from.

    d : (T,) left minus right ankle along the walking direction (nan = missing). A meeting is a
    minimum of |d| at least ``meeting_m`` below the largest |d| on either side of it (its
    prominence), so jitter on a plateau is none; between two meetings lies one step, whose sign
    is that of its largest |d|. Walking alternates the signs (the legs pass each other), so two
    steps of the same sign in a row mean the labels were exchanged at the meeting between them,
    however close the model's ankles came.
    """
    rows = np.nonzero(np.isfinite(d))[0]
    a = np.abs(d[rows])
    meet = find_peaks(-a, prominence=meeting_m)[0].tolist()
    out = []
    for i, k in enumerate(meet):
        lo, hi = ([0] + meet)[i], (meet + [len(rows) - 1])[i + 1]
        before, after = np.arange(lo, k), np.arange(k + 1, hi + 1)
        if len(before) == 0 or len(after) == 0:
            continue
        pb, pa = before[np.argmax(a[before])], after[np.argmax(a[after])]
        if np.sign(d[rows[pb]]) == np.sign(d[rows[pa]]):
            out.append(int(rows[k]))
    return out


def detect_leg_swaps(joints: np.ndarray, up: np.ndarray, frames: np.ndarray | None = None, *,
                     min_gain_m: float = MIN_GAIN_M, ratio: float = RATIO,
                     meeting_m: float | None = MEETING_M) -> LegSwaps:
    """Find label exchanges in a (T, J, 3) walking trajectory (nan rows = missing).

    Two kinds (see module doc): jumps (the exchanged labels continue the previous two frames
    better, by ``min_gain_m`` and a factor ``1 / ratio``), then, on the jump-corrected legs,
    bounces (the ankles come together by at least ``meeting_m`` along the walking direction and
    part on the sides they came from; ``None`` skips this test, e.g. for a person who stops or
    turns on the spot).
    frames : (T,) frame numbers (gaps scale the velocity prediction); default 0..T-1.
    """
    legs = sagittal_legs(joints, up)
    frames = np.arange(len(legs)) if frames is None else np.asarray(frames)
    jumps, gain = _jumps(legs, frames, min_gain_m, ratio)
    parity = np.zeros(len(legs), bool)
    for t in jumps:
        parity[t:] ^= True
    swaps = list(jumps)
    if meeting_m is not None:
        fixed = np.where(parity[:, None], legs[:, ::-1, 1, 0], legs[:, :, 1, 0])  # ankles, forward
        for t in _bounces(fixed[:, 0] - fixed[:, 1], meeting_m):
            parity[t:] ^= True
            swaps.append(t)
    return LegSwaps(np.array(sorted(swaps), int), parity, gain)


def _leg_dof_pairs() -> tuple[list[int], list[int]]:
    return ([DOF_INDEX[f"left_{d}"] for d in LEG_DOFS], [DOF_INDEX[f"right_{d}"] for d in LEG_DOFS])


def swap_leg_dofs(poses: np.ndarray, parity: np.ndarray) -> np.ndarray:
    """(T, D) poses with the left and right leg DOFs exchanged on the rows where ``parity``."""
    out = np.array(poses, float)
    left, right = _leg_dof_pairs()
    out[np.ix_(parity, left + right)] = np.asarray(poses, float)[np.ix_(parity, right + left)]
    return out


def swap_leg_points(joints: np.ndarray, parity: np.ndarray) -> np.ndarray:
    """(T, J, 3) joints with the legs below the hips exchanged on the rows where ``parity``; each
    moved leg is translated by the hips' offset so it stays attached to its own hip."""
    out = np.array(joints, float)
    hl, hr = POINT_INDEX["left_hip"], POINT_INDEX["right_hip"]
    offset = out[parity, hl] - out[parity, hr]  # (K, 3)
    for p in LEG_POINTS:
        li, ri = POINT_INDEX[f"left_{p}"], POINT_INDEX[f"right_{p}"]
        left, right = joints[parity, li], joints[parity, ri]
        out[parity, li] = right + offset
        out[parity, ri] = left - offset
    return out
