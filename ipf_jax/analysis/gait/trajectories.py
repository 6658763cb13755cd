"""Trajectories: the named body points of a walk over time, in metres, with the up axis known."""
from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

import numpy as np

from ...body.model import POINT_NAMES
from ...errors import IPFError
from ...geometry.world import AXES, axis_vector

UNIT_SCALE = {"m": 1.0, "mm": 1e-3}


class Trajectories(NamedTuple):
    """Body points over time, as read from one file (T frames).

    time : (T,) float64 seconds on the input's own clock (joints.csv ``time_s``, the TRC ``Time``
        column, C3D ``(first_frame + i) / rate``).
    points : dict role -> (T, 3) float64 metres in the file's frame; NaN where missing. Roles are
        names from :data:`ipf_jax.body.model.POINT_NAMES`; absent roles are absent keys.
    up : (3,) unit up vector of the file's frame.  up_axis : the same as ``+x`` ... ``-z``.
    fps : frame rate (Hz).  source : the file read.
    notes : human-readable remarks made while reading (marker averaging, unit choices).
    """

    time: np.ndarray
    points: dict
    up: np.ndarray
    up_axis: str
    fps: float
    source: str
    notes: tuple = ()


def make_trajectories(time: np.ndarray, points: dict, *, up_axis: str, source: str | Path,
                      fps: float | None = None, notes: tuple = ()) -> Trajectories:
    """Validate arrays and build :class:`Trajectories` (the one constructor every reader uses).

    time : (T,) seconds, strictly increasing.  points : role -> (T, 3) metres.
    ``fps`` defaults to the median sampling rate of ``time``.
    """
    time = np.asarray(time, dtype=float)
    if time.ndim != 1 or len(time) < 2:
        raise IPFError(f"needs at least 2 frames, found {time.size}", source)
    if not np.all(np.isfinite(time)) or np.any(np.diff(time) <= 0):
        raise IPFError("time column is not finite and strictly increasing", source)
    unknown = sorted(set(points) - set(POINT_NAMES))
    if unknown:
        raise IPFError(f"unknown point names {unknown} (known: {', '.join(POINT_NAMES)})", source)
    pts = {}
    for name in POINT_NAMES:
        if name in points:
            arr = np.asarray(points[name], dtype=float)
            if arr.shape != (len(time), 3):
                raise IPFError(f"point {name} has shape {arr.shape}, expected ({len(time)}, 3)",
                               source)
            pts[name] = arr
    if not pts:
        raise IPFError("no body points", source)
    if up_axis not in AXES:
        raise IPFError(f"unknown up axis {up_axis!r} (choose one of {', '.join(AXES)})", source)
    # rounded so that a 20 Hz clock written as 0.05 s steps reads as exactly 20 Hz
    rate = float(fps) if fps else round(float(1.0 / np.median(np.diff(time))), 6)
    return Trajectories(time, pts, axis_vector(up_axis), up_axis, rate, str(source), tuple(notes))
