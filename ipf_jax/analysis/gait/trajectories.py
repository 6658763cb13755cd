"""The in-memory form every gait reader produces: body points over time, in metres, with an up axis.

:class:`Trajectories` is what the analysis consumes, whatever the file was (``joints.csv``,
``.trc``, ``.c3d``); :func:`make_trajectories` is the one constructor every reader goes through,
so that the checks (clock, shapes, finite values, plausible sizes) live in one place.
"""
from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

import numpy as np

from ...body.model import POINT_NAMES
from ...errors import IPFError
from ...geometry.world import AXES, axis_vector

#: Metres per unit for the ``--units`` choices.
UNIT_SCALE = {"m": 1.0, "cm": 1e-2, "mm": 1e-3}
#: Roles a trajectory may hold: the 19 body points, plus ``pelvis`` (a pelvis reference such as
#: the mean of the four iliac spine markers) that stands in for a sacrum marker with no data.
ROLES = POINT_NAMES + ("pelvis",)
#: Coordinates farther than this from the origin (metres) are read as missing: no lab, and no
#: camera volume, is 1 km across; larger values are placeholders or corruption.
MAX_ABS_M = 1000.0


class Trajectories(NamedTuple):
    """Body points over time, as read from one file (T frames).

    time : (T,) float64 seconds on the input's own clock (joints.csv ``time_s``, the TRC ``Time``
        column, C3D ``(first_frame + i) / rate``).
    points : dict role -> (T, 3) float64 metres in the file's frame; NaN where missing. Roles are
        names from :data:`ROLES`; absent roles are absent keys.
    up : (3,) unit up vector of the file's frame.  up_axis : the same as ``+x`` ... ``-z``.
    fps : frame rate (Hz).  source : the file read.
    notes : human-readable remarks made while reading (marker set, units, up axis, gaps).
    cameras : number of cameras that produced the points (``run.json``), None for marker systems
        or when unknown; with one camera the depth across its line of sight is not measured.
    """

    time: np.ndarray
    points: dict
    up: np.ndarray
    up_axis: str
    fps: float
    source: str
    notes: tuple = ()
    cameras: int | None = None


def make_trajectories(time: np.ndarray, points: dict, *, up_axis: str, source: str | Path,
                      fps: float | None = None, notes: tuple = (),
                      cameras: int | None = None) -> Trajectories:
    """Validate arrays and build :class:`Trajectories`.

    time : (T,) seconds, strictly increasing.  points : role -> (T, 3) metres; non-finite values
    and values beyond :data:`MAX_ABS_M` become NaN (missing), with a note. ``fps`` defaults to the
    median sampling rate of ``time``.
    """
    time = np.asarray(time, dtype=float)
    if time.ndim != 1 or len(time) < 2:
        raise IPFError(f"needs at least 2 frames, found {time.size}", source)
    if not np.all(np.isfinite(time)) or np.any(np.diff(time) <= 0):
        raise IPFError("time column is not finite and strictly increasing", source)
    unknown = sorted(set(points) - set(ROLES))
    if unknown:
        raise IPFError(f"unknown point names {unknown} (known: {', '.join(ROLES)})", source)
    pts, bad = {}, 0
    for name in ROLES:
        if name in points:
            arr = np.array(points[name], dtype=float)
            if arr.shape != (len(time), 3):
                raise IPFError(f"point {name} has shape {arr.shape}, expected ({len(time)}, 3)",
                               source)
            with np.errstate(invalid="ignore"):
                wrong = np.any(np.isinf(arr) | (np.abs(arr) > MAX_ABS_M), axis=1)
            bad += int(wrong.sum())
            arr[wrong] = np.nan
            pts[name] = arr
    if not pts:
        raise IPFError("no body points", source)
    if up_axis not in AXES:
        raise IPFError(f"unknown up axis {up_axis!r} (choose one of {', '.join(AXES)})", source)
    notes = tuple(notes)
    if bad:
        notes += ((f"{bad} point samples infinite or farther than {MAX_ABS_M:g} m from the "
                   "origin read as missing"),)
    # rounded so that a 20 Hz clock written as 0.05 s steps reads as exactly 20 Hz
    rate = float(fps) if fps else round(float(1.0 / np.median(np.diff(time))), 6)
    if not (np.isfinite(rate) and rate > 0):
        raise IPFError(f"frame rate must be positive, got {rate}", source)
    return Trajectories(time, pts, axis_vector(up_axis), up_axis, rate, str(source), notes,
                        cameras)
