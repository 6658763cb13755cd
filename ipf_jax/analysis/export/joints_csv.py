"""CSV export: joints.csv again, optionally in another length unit and up axis.

Same layout as the run's ``joints.csv`` (``frame,time_s,<point>_x,...``, ``nan`` for missing
points), so existing readers keep working in metres. In another unit the coordinate columns are
named ``<point>_x_<unit>`` so a millimetre file is never mistaken for metres.
"""
from __future__ import annotations

from pathlib import Path

from ...data.rundir import Run
from ...data.runfiles import JOINT_COLUMNS, write_rows
from .axes import decimals, to_file_frame


def export_csv(run: Run, path: str | Path, *, up: str | None = None, units: str = "m") -> Path:
    """Write the run's 19 points as CSV.

    up : file up axis; None keeps the world frame. units : m (default), cm or mm.
    """
    path = Path(path)
    up = run.up_axis if up is None else up
    pts = to_file_frame(run.joints, run.up_axis, up, units)  # (T, J, 3)
    header = JOINT_COLUMNS[:2] + [c if units == "m" else f"{c}_{units}" for c in JOINT_COLUMNS[2:]]
    write_rows(path, header, run.frames, run.time_s, pts.reshape(len(pts), -1), decimals(units))
    return path
