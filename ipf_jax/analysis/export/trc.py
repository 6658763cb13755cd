"""TRC (Track Row Column) marker files, the text format OpenSim reads as marker trajectories.

Layout (tab-separated): the ``PathFileType`` line, the metadata keys and values (``DataRate``,
``Units``, ...), a label line ``Frame# Time <marker> ...`` (one name per three columns), an
``X1 Y1 Z1 ...`` line, a blank line, then one row per frame. A missing marker is three empty
fields; every field is followed by a tab, as OpenSim's own writer does, so the field count stays
right even when the last marker is empty. The reader is :func:`ipf_jax.analysis.gait.markers.read_trc`.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ...body.model import POINT_NAMES
from ...data.rundir import Run, sample_rate
from ...errors import IPFError
from .axes import decimals, to_file_frame, unit_scale

_KEYS = ("DataRate", "CameraRate", "NumFrames", "NumMarkers", "Units", "OrigDataRate",
         "OrigDataStartFrame", "OrigNumFrames")


def _field(x: float, fmt: str) -> str:
    return "" if not np.isfinite(x) else fmt % x


def export_trc(run: Run, path: str | Path, *, up: str = "+y", units: str = "mm") -> Path:
    """Write the run's 19 points as a TRC file.

    Frames are numbered 1..T, ``Time`` is the run's ``time_s``; every row of joints.csv is written,
    missing points as empty fields. ``up``: file up axis (OpenSim: ``+y``); ``units``: m, cm or mm.
    """
    path = Path(path)
    unit_scale(units)
    rate = sample_rate(run)
    pts = to_file_frame(run.joints, run.up_axis, up, units)  # (T, J, 3)
    pts = np.where(np.isfinite(pts).all(-1, keepdims=True), pts, np.nan)
    T, J, _ = pts.shape
    fmt, r = f"%.{decimals(units)}f", f"{rate:.10g}"
    lines = [
        f"PathFileType\t4\t(X/Y/Z)\t{path.name}",
        "\t".join(_KEYS),
        "\t".join(map(str, (r, r, T, J, units, r, 1, T))),
        "Frame#\tTime\t" + "".join(f"{name}\t\t\t" for name in POINT_NAMES),
        "\t\t" + "".join(f"X{i}\tY{i}\tZ{i}\t" for i in range(1, J + 1)),
        "",
    ]
    for t in range(T):
        values = "".join(_field(v, fmt) + "\t" for v in pts[t].ravel())
        lines.append(f"{t + 1}\t{run.time_s[t]:.6f}\t{values}")
    try:
        path.write_text("\n".join(lines) + "\n")
    except OSError as e:
        raise IPFError(f"cannot write ({e})", path) from None
    return path
