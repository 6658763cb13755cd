"""Read walking trajectories from any supported file into one in-memory form.

Three inputs are accepted (see ``docs/gait.md``): the tracker's ``joints.csv`` (or any CSV in that
convention holding a subset of the 19 points), marker files ``.trc`` and ``.c3d`` turned into body
points through a marker map (:mod:`.markers`). Whatever the source, the result is a
:class:`Trajectories`: seconds on the input's own clock, metres, and the world's up vector, so the
analysis never needs to know where the data came from.
"""
from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np

from ...body.model import POINT_NAMES
from ...errors import IPFError, load_json
from .trajectories import UNIT_SCALE, Trajectories, make_trajectories


#: Metres per unit for the ``--units`` choices.
def load(path: str | Path, *, marker_map: str | Path | None = None, up: str | None = None,
         units: str | None = None) -> Trajectories:
    """Read a ``joints.csv``-style CSV, a ``.trc`` or a ``.c3d`` file.

    ``marker_map`` (TRC/C3D only) is a JSON file of roles -> marker names; the default is the
    shipped Rajagopal map. ``up`` (``+x`` ... ``-z``) and ``units`` (``m``/``mm``) override what the
    file says. Raises :class:`IPFError` naming the file for anything unreadable.
    """
    path = Path(path)
    if not path.is_file():
        raise IPFError("file not found", path)
    if units is not None and units not in UNIT_SCALE:
        raise IPFError(f"unknown units {units!r} (choose m or mm)", path)
    suffix = path.suffix.lower()
    if suffix == ".csv":
        if marker_map is not None:
            raise IPFError("--marker-map applies to .trc/.c3d marker files, not to a joints CSV",
                           path)
        return read_joints_csv(path, up=up, units=units)
    if suffix in (".trc", ".c3d"):
        from . import markers

        return markers.read_marker_file(path, marker_map=marker_map, up=up, units=units)
    raise IPFError(f"unknown file type {path.suffix!r} (expected .csv joints, .trc or .c3d)", path)


def read_joints_csv(path: str | Path, *, up: str | None = None,
                    units: str | None = None) -> Trajectories:
    """Read a CSV in the ``joints.csv`` convention (``frame,time_s,<point>_x,_y,_z...``).

    Any subset of the 19 points is accepted; columns that are not ``<point>_<x|y|z>`` of a known
    point (e.g. ``source_time_s``) are ignored. ``nan`` or empty cells mark missing values. The up
    axis comes from ``run.json`` beside the file unless ``up`` is given; without either it is an
    error, because guessing it would silently swap walking and vertical motion.
    """
    path = Path(path)
    try:
        with path.open(newline="") as f:
            rows = list(csv.reader(f))
    except (OSError, UnicodeDecodeError) as e:
        raise IPFError(f"cannot read ({e})", path) from None
    if not rows or "time_s" not in [c.strip() for c in rows[0]]:
        raise IPFError("not a joints CSV: the header has no 'time_s' column", path)
    header = [c.strip() for c in rows[0]]
    body = [r for r in rows[1:] if any(c.strip() for c in r)]
    if not body:
        raise IPFError("no data rows", path)
    for i, r in enumerate(body):
        if len(r) != len(header):
            raise IPFError(f"row {i + 2} has {len(r)} fields, the header has {len(header)} "
                           "(truncated or malformed file)", path)
    try:
        table = np.array([[float(c) if c.strip() else np.nan for c in r] for r in body])
    except ValueError as e:
        raise IPFError(f"non-numeric value ({e})", path) from None
    col = {name: i for i, name in enumerate(header)}
    points = {}
    for name in POINT_NAMES:
        keys = [f"{name}_{c}" for c in "xyz"]
        if all(k in col for k in keys):
            points[name] = table[:, [col[k] for k in keys]]
    if not points:
        raise IPFError("no <point>_x,<point>_y,<point>_z columns of known body points", path)
    scale = UNIT_SCALE[units] if units else 1.0
    points = {k: v * scale for k, v in points.items()}
    meta = _run_json(path)
    up_axis = up or meta.get("up_axis")
    if up_axis is None:
        raise IPFError("no run.json with 'up_axis' beside the file: give the up axis with --up",
                       path)
    notes = [f"up axis {up_axis} from " + ("the up option" if up else "run.json")]
    return make_trajectories(table[:, col["time_s"]], points, up_axis=up_axis, source=path,
                             fps=meta.get("fps"), notes=tuple(notes))


def write_joints_csv(traj: Trajectories, path: str | Path, *, run_json: bool = True) -> Path:
    """Write ``traj`` as a joints.csv (its points only, 6 decimals, ``nan`` for missing).

    With ``run_json`` a ``run.json`` holding ``up_axis`` and ``fps`` is written beside it, as the
    tracker does.
    """
    path = Path(path)
    names = [n for n in POINT_NAMES if n in traj.points]
    header = ["frame", "time_s"] + [f"{n}_{c}" for n in names for c in "xyz"]
    table = np.concatenate([traj.points[n] for n in names], axis=1)
    lines = [",".join(header)]
    for i, (t, row) in enumerate(zip(traj.time, table)):
        lines.append(",".join([str(i), f"{t:.6f}"] + [f"{v:.6f}" for v in row]))
    path.write_text("\n".join(lines) + "\n")
    if run_json:
        path.with_name("run.json").write_text(json.dumps({"up_axis": traj.up_axis,
                                                          "fps": traj.fps}))
    return path


def _run_json(csv_path: Path) -> dict:
    """``run.json`` beside a joints CSV, or ``{}`` when there is none."""
    meta_path = csv_path.with_name("run.json")
    if not meta_path.is_file():
        return {}
    meta = load_json(meta_path, "run.json")
    if not isinstance(meta, dict):
        raise IPFError("expected a JSON object", meta_path)
    return meta
