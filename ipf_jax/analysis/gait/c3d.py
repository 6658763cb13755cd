"""Read ``.c3d`` marker files with ezc3d, after :mod:`.c3d_check` has validated their structure.

Time of stored frame ``i`` is ``(first_frame + i) / rate`` with ezc3d's 0-based first frame, so
events stay on the clock of the file's analog data (force plates) and of its EVENT group. A
marker sample is missing when its residual is negative (the C3D convention), when it is exactly
(0, 0, 0), or when it is not finite. ``POINT:UNITS`` gives the unit and ``POINT:Y_SCREEN`` an up
axis *hint* (a viewing setting, checked against the body by :mod:`.markers`).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ...errors import IPFError
from ...geometry.world import AXES
from .c3d_check import check_c3d
from .markerdata import MarkerData, from_columns, normalise_units


def read_c3d(path: str | Path) -> MarkerData:
    """Read the 3-D points of a ``.c3d`` file; raises :class:`IPFError` naming the file."""
    path = Path(path)
    layout = check_c3d(path)
    import ezc3d  # C++ extension: loaded only when a C3D file is read

    try:
        c3d = ezc3d.c3d(str(path))
        params = c3d["parameters"]["POINT"]
        labels = [str(s).strip() for s in params["LABELS"]["value"]]
        k = 2
        while f"LABELS{k}" in params:
            labels += [str(s).strip() for s in params[f"LABELS{k}"]["value"]]
            k += 1
        rate = float(c3d["header"]["points"]["frame_rate"])
        first = int(c3d["header"]["points"]["first_frame"])
        data = np.asarray(c3d["data"]["points"], dtype=float)          # (4, M, T)
        residuals = np.asarray(c3d["data"]["meta_points"]["residuals"], dtype=float)
        units_param = params.get("UNITS", {}).get("value") or [None]
        screen = params.get("Y_SCREEN", {}).get("value") or [None]
    except Exception as e:  # noqa: BLE001 - ezc3d raises RuntimeError/IOError/IndexError/...
        raise IPFError(f"cannot read C3D ({type(e).__name__}: {e})", path) from None
    if data.ndim != 3 or data.shape[0] < 3 or data.shape[2] < 2 or not labels:
        raise IPFError(f"C3D has no usable point data ({data.shape[2] if data.ndim == 3 else 0} "
                       f"frames, {len(labels)} labels)", path)
    if not (np.isfinite(rate) and rate > 0):
        rate = layout.rate
    xyz = data[:3].transpose(1, 2, 0).copy()                           # (M, T, 3)
    if residuals.shape == (1,) + xyz.shape[:2]:
        xyz[residuals[0] < 0] = np.nan
    markers, notes = from_columns(labels[:xyz.shape[0]], xyz[:len(labels)])
    unit = normalise_units(units_param[0] if units_param[0] else None)
    hint = str(screen[0]).strip().lower() if screen[0] else None
    time = (first + np.arange(xyz.shape[1])) / rate
    return MarkerData(time, markers, unit, rate, hint if hint in AXES else None, notes)
