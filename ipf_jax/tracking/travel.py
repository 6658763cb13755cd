"""The direction a walker travels, from where the silhouettes stand over about a second.

Silhouettes do not tell a person's front from their back: someone walking away from a camera and
someone walking backwards towards it, the other leg forward, cover nearly the same pixels, and on
a noisy frame the search can settle on the wrong one (issue 15: one of 30 runs on the visible
walks tracked a walker backwards for the whole clip). Where the person stands, though, is not
ambiguous: the silhouettes' viewing rays meet over the same floor point whichever way the body
faces (:func:`ipf_jax.tracking.initialise.floor_points`). A walker faces the way they go, so when
that point moves steadily by more than :data:`MIN_TRAVEL_M` within about a second, the automatic
initialisation searches only the headings within 90 deg of the direction of travel
(``--facing-travel``, on by default). Standing, sitting down, turning on the spot: no direction,
all headings.
"""
from __future__ import annotations

import numpy as np

#: Least floor distance (m) between the first and last floor points to call it travel: a third of
#: a slow step (0.5 m/s over the window's second is 0.5 m), far above the floor point's jitter
#: from frame to frame (a few cm as the legs swing).
MIN_TRAVEL_M = 0.3
#: Time spanned by the floor points (s), and how many are taken over it (the first included).
WINDOW_S = 1.0
SAMPLES = 3


def window_frames(frames: list[int], frame: int, fps: float) -> list[int]:
    """:data:`SAMPLES` frames of ``frames``, in time order, spanning :data:`WINDOW_S` from ``frame``
    on (or the last :data:`WINDOW_S` of the recording when it ends sooner; all of it when shorter)."""
    frames = sorted(frames)
    span = max(1, int(round(WINDOW_S * fps)))
    hi = min(len(frames) - 1, frames.index(frame) + span)
    lo = max(0, hi - span)
    picks = [lo + round(k * (hi - lo) / (SAMPLES - 1)) for k in range(SAMPLES)]
    return [frames[k] for k in dict.fromkeys(picks)]  # distinct, in order


def travel_heading(points: list[np.ndarray], U: np.ndarray, min_travel_m: float = MIN_TRAVEL_M) -> float | None:
    """The heading (rad, the root yaw of a body facing that way: body x along ``U``'s first column
    at 0) of the travel through the floor points (each (3,), in time order), or None when they move
    less than ``min_travel_m`` or not steadily one way (a step back against the overall direction)."""
    if len(points) < 2:
        return None
    P = np.asarray(points, float)
    east, north = U[:, 0], U[:, 1]
    xy = np.stack([P @ east, P @ north], axis=1)
    d = xy[-1] - xy[0]
    dist = float(np.hypot(*d))
    if not np.isfinite(dist) or dist < min_travel_m:
        return None
    steps = np.diff(xy, axis=0) @ (d / dist)
    if np.any(steps <= 0):
        return None
    return float(np.arctan2(d[1], d[0]))


__all__ = ["MIN_TRAVEL_M", "SAMPLES", "WINDOW_S", "travel_heading", "window_frames"]
