"""Read walking trajectories from any supported file into one in-memory form.

Three inputs are accepted (see ``docs/gait.md``): the tracker's ``joints.csv`` (or any CSV in that
convention holding a subset of the 19 points), marker files ``.trc`` and ``.c3d`` turned into body
points through a recognised marker set or a marker map (:mod:`.markers`). Whatever the source,
the result is a :class:`~.trajectories.Trajectories`: seconds on the input's own clock, metres,
and the world's up vector, so the analysis never needs to know where the data came from.

A ``run.json`` beside the input (as ``ipf-jax track`` writes it) gives the up axis of a
joints CSV and the number of cameras (its ``cameras`` list): with one camera the depth across
its line of sight is not measured, and the analysis says so instead of giving numbers.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ...body.model import POINT_NAMES
from ...data.runfiles import read_table
from ...errors import IPFError, load_json
from .markers import read_marker_file
from .trajectories import UNIT_SCALE, Trajectories, make_trajectories
from .vertical import infer_up, warn_if_contradicted

__all__ = [
    "UNIT_SCALE",
    "Trajectories",
    "load",
    "make_trajectories",
    "read_joints_csv",
    "write_joints_csv",
]



def load(path: str | Path, *, marker_map: str | Path | None = None, up: str | None = None,
         units: str | None = None, cameras: int | None = None) -> Trajectories:
    """Read a ``joints.csv``-style CSV, a ``.trc`` or a ``.c3d`` file.

    ``marker_map`` (TRC/C3D only) is a JSON file of roles -> marker names; without one the
    marker set is recognised. ``up`` (``+x`` ... ``-z``) and ``units`` (``m``/``cm``/``mm``)
    override what the file says; ``cameras`` overrides ``run.json``'s camera count. Raises
    :class:`IPFError` naming the file for anything unreadable.
    """
    path = Path(path)
    if path.is_dir():
        raise IPFError("is a folder: give a joints CSV (e.g. a run's joints.csv), a .trc or a .c3d file",
                       path)
    if not path.is_file():
        raise IPFError("file not found", path)
    if units is not None and units not in UNIT_SCALE:
        raise IPFError(f"unknown units {units!r} (choose {', '.join(UNIT_SCALE)})", path)
    if cameras is not None and (not isinstance(cameras, int) or cameras < 1):
        raise IPFError(f"the number of cameras must be a positive integer, got {cameras!r}")
    meta = _run_json(path)
    if cameras is None:
        cameras = _camera_count(meta, path)
    suffix = path.suffix.lower()
    if suffix == ".csv":
        if marker_map is not None:
            raise IPFError("--marker-map applies to .trc/.c3d marker files, not to a joints CSV",
                           path)
        return read_joints_csv(path, up=up, units=units, meta=meta, cameras=cameras)
    if suffix in (".trc", ".c3d"):
        return read_marker_file(path, marker_map=marker_map, up=up, units=units,
                                cameras=cameras)
    raise IPFError(f"unknown file type {path.suffix!r} (expected .csv joints, .trc or .c3d)", path)


def read_joints_csv(path: str | Path, *, up: str | None = None, units: str | None = None,
                    meta: dict | None = None, cameras: int | None = None) -> Trajectories:
    """Read a CSV in the ``joints.csv`` convention (``frame,time_s,<point>_x,_y,_z...``).

    Any subset of the 19 points is accepted; columns that are not ``<point>_<x|y|z>`` of a known
    point (e.g. ``source_time_s``) are ignored. ``nan`` or empty cells mark missing values. The up
    axis is ``up``, else ``run.json``'s ``up_axis``, else the body's (:mod:`.vertical`).
    """
    path = Path(path)
    header, table = read_table(path, "joints CSV")
    if "time_s" not in header:
        raise IPFError("not a joints CSV: the header has no 'time_s' column", path)
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
    meta = _run_json(path) if meta is None else meta
    up_axis, source = up, "the up option"
    if up is not None:
        warn_if_contradicted(points, up, path.name)
    if up_axis is None and meta.get("up_axis") is not None:
        up_axis, source = meta["up_axis"], "run.json"
    if up_axis is None:
        up_axis, why = infer_up(points)
        if up_axis is None:
            raise IPFError(f"no run.json with 'up_axis' beside the file, and the body does not "
                           f"show it ({why}): give the up axis with --up", path)
        source = f"the body ({why})"
    notes = [f"up axis {up_axis} from {source}"]
    if cameras:
        notes.append(f"{cameras} camera{'s' if cameras > 1 else ''} (run.json)")
    lost = _lost_frames(meta)
    if lost:
        notes.append(f"{len(lost)} frame{'s' if len(lost) > 1 else ''} the tracker declared lost "
                     f"(run.json: {_spans(lost)}) are gaps, like missing frames")
    fps = meta.get("fps")
    fps = float(fps) if isinstance(fps, (int, float)) and not isinstance(fps, bool) \
        and np.isfinite(fps) and fps > 0 else None
    # the run's fps is its dataset's; rows may be every k-th frame, so trust the time column
    # unless it matches
    time = table[:, col["time_s"]]
    if (fps and len(time) > 1 and np.all(np.isfinite(time)) and np.median(np.diff(time)) > 0
            and abs(1.0 / np.median(np.diff(time)) - fps) > 0.01 * fps):
        fps = None
    return make_trajectories(time, points, up_axis=up_axis, source=path, fps=fps,
                             notes=tuple(notes), cameras=cameras)


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


def _lost_frames(meta: dict) -> list[int]:
    """Frame numbers whose ``run.json`` status is ``lost`` (written as nan rows)."""
    per_frame = meta.get("per_frame")
    if not isinstance(per_frame, list):
        return []
    return [r["frame"] for r in per_frame if isinstance(r, dict) and r.get("status") == "lost"
            and isinstance(r.get("frame"), int)]


def _spans(frames: list[int]) -> str:
    """'frames 3-5, 9' for [3, 4, 5, 9] (frame numbers in order)."""
    runs: list[list[int]] = []
    for f in frames:
        if runs and f == runs[-1][-1] + 1:
            runs[-1].append(f)
        else:
            runs.append([f])
    return "frames " + ", ".join(f"{r[0]}" if len(r) == 1 else f"{r[0]}-{r[-1]}" for r in runs)


def _run_json(path: Path) -> dict:
    """``run.json`` beside the input, or ``{}`` when there is none."""
    meta_path = path.with_name("run.json")
    if not meta_path.is_file():
        return {}
    meta = load_json(meta_path, "run.json")
    if not isinstance(meta, dict):
        raise IPFError("expected a JSON object", meta_path)
    return meta


def _camera_count(meta: dict, path: Path) -> int | None:
    cams = meta.get("cameras")
    if cams is None:
        return None
    n = len(cams) if isinstance(cams, list) else cams
    if isinstance(n, bool) or not isinstance(n, int) or n < 1:
        raise IPFError(f"'cameras' must be a list of camera names or a positive count, got "
                       f"{cams!r}", path.with_name("run.json"))
    return n
