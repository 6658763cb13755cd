"""Marker files (``.trc``, ``.c3d``) and the marker maps that turn markers into body points.

A marker map is JSON, either ``{"roles": {role: marker | [markers]}}`` (optionally with ``name`` and
``description``) or the bare ``{role: marker | [markers]}`` object. A list is averaged per frame
(e.g. sacrum = mean of the two PSIS markers); a frame where any listed marker is missing is
missing for the role, since an average of fewer markers would jump. The default map for the
OpenSim Rajagopal marker set ships as ``ipf_jax/gait/maps/rajagopal.json``.

Units: TRC ``Units`` header, C3D ``POINT:UNITS``; ``--units`` overrides. Up axis: C3D
``POINT:Y_SCREEN`` (the axis drawn upwards by the recording software) when present, else ``+y``
(the usual lab convention, and OpenSim's); ``--up`` overrides.
"""
from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

import numpy as np

from ...body.model import POINT_NAMES
from ...errors import IPFError, load_json
from ...geometry.world import AXES
from .trajectories import UNIT_SCALE, Trajectories, make_trajectories

DEFAULT_MAP = Path(__file__).with_name("maps") / "rajagopal.json"


class MarkerData(NamedTuple):
    """Raw markers of one file (T frames, M markers).

    time : (T,) seconds.  markers : dict name -> (T, 3) in the file's units (NaN = missing).
    units : ``m``/``mm`` as the file says (None when it does not).  rate : Hz.
    up_axis : the file's up axis when it states one, else None.
    """

    time: np.ndarray
    markers: dict
    units: str | None
    rate: float
    up_axis: str | None


def read_marker_file(path: str | Path, *, marker_map: str | Path | None = None,
                     up: str | None = None, units: str | None = None) -> Trajectories:
    """Read a ``.trc``/``.c3d`` file and map its markers to body points (see module docs)."""
    path = Path(path)
    raw = read_c3d(path) if path.suffix.lower() == ".c3d" else read_trc(path)
    map_path = Path(marker_map) if marker_map is not None else DEFAULT_MAP
    roles = load_marker_map(map_path)
    unit = units or raw.units
    if unit is None:
        raise IPFError("the file does not state its units: give --units m or mm", path)
    if unit not in UNIT_SCALE:
        raise IPFError(f"unsupported units {unit!r} (give --units m or mm)", path)
    up_axis = up or raw.up_axis or "+y"
    points, notes = apply_marker_map(raw.markers, roles, data_path=path, map_path=map_path)
    scale = UNIT_SCALE[unit]
    points = {k: v * scale for k, v in points.items()}
    source_of_up = "the up option" if up else ("the file" if raw.up_axis else "lab default (Y up)")
    notes = (f"marker map {map_path.name}", f"units {unit}", f"up axis {up_axis} from "
             f"{source_of_up}", *notes)
    return make_trajectories(raw.time, points, up_axis=up_axis, source=path, fps=raw.rate,
                             notes=notes)


# --------------------------------------------------------------------------------------------------
# Marker maps


def load_marker_map(path: str | Path) -> dict:
    """Read a marker map JSON -> ``{role: (marker, ...)}`` with every role a known body point."""
    path = Path(path)
    doc = load_json(path, "marker map")
    roles = doc.get("roles", doc) if isinstance(doc, dict) else None
    if not isinstance(roles, dict) or not roles:
        raise IPFError("marker map must be a JSON object of role -> marker name(s)", path)
    if "roles" not in doc:
        roles = {k: v for k, v in roles.items() if k not in ("name", "description")}
    out = {}
    for role, names in roles.items():
        if role not in POINT_NAMES:
            raise IPFError(f"marker map role {role!r} is not a body point "
                           f"(known: {', '.join(POINT_NAMES)})", path)
        names = [names] if isinstance(names, str) else names
        if (not isinstance(names, list) or not names
                or not all(isinstance(n, str) and n for n in names)):
            raise IPFError(f"marker map role {role!r} must be a marker name or a non-empty list "
                           "of names", path)
        out[role] = tuple(names)
    return out


def apply_marker_map(markers: dict, roles: dict, *, data_path: str | Path,
                     map_path: str | Path) -> tuple[dict, tuple]:
    """Body points from markers: role -> (T, 3) (averaged lists), plus notes on the averaging.

    Every marker the map names must exist in the file, otherwise :class:`IPFError` lists the
    missing ones: a map that silently drops a foot would give wrong gait events.
    """
    missing = [f"{role} -> {n}" for role, names in roles.items() for n in names
               if n not in markers]
    if missing:
        have = ", ".join(sorted(markers)[:60])
        raise IPFError(f"marker map {Path(map_path).name} names markers the file does not have: "
                       f"{'; '.join(missing)} (the file has: {have}); fix the map or pass "
                       "another --marker-map", data_path)
    points, notes = {}, []
    for role, names in roles.items():
        stack = np.stack([markers[n] for n in names])                 # (K, T, 3)
        points[role] = stack.mean(axis=0)
        if len(names) > 1:
            notes.append(f"{role} = mean of {', '.join(names)}")
    return points, tuple(notes)


# --------------------------------------------------------------------------------------------------
# TRC


def read_trc(path: str | Path) -> MarkerData:
    """Read an OpenSim/Vicon ``.trc`` text file (tab-separated; empty cells = missing marker)."""
    path = Path(path)
    try:
        lines = path.read_text(errors="strict").splitlines()
    except (OSError, UnicodeDecodeError) as e:
        raise IPFError(f"cannot read TRC ({e})", path) from None
    if len(lines) < 5 or not lines[0].startswith("PathFileType"):
        raise IPFError("not a TRC file (no 'PathFileType' header, or the header is cut short)",
                       path)
    # values are padded with runs of tabs and spaces; neither keys nor values contain blanks
    header = dict(zip(lines[1].split(), lines[2].split()))
    try:
        rate = float(header["DataRate"])
        n_frames = int(float(header["NumFrames"]))
        n_markers = int(float(header["NumMarkers"]))
    except (KeyError, ValueError):
        raise IPFError("TRC header lacks a numeric DataRate, NumFrames or NumMarkers", path) \
            from None
    names_row = lines[3].split("\t")
    if len(names_row) < 2 or names_row[1].strip().lower() != "time":
        raise IPFError("TRC line 4 must start with 'Frame#<tab>Time'", path)
    names = [n.strip() for n in names_row[2:] if n.strip()]
    if len(names) != n_markers:
        raise IPFError(f"TRC header says {n_markers} markers, line 4 names {len(names)}", path)
    rows, counts = [], []
    width = 2 + 3 * n_markers
    for lineno, line in enumerate(lines[5:], start=6):
        if not line.strip():
            continue
        cells = line.rstrip("\r\n").split("\t")
        if len(cells) < 2:
            raise IPFError(f"line {lineno}: truncated TRC row", path)
        counts.append(len(cells))
        cells = (cells + [""] * width)[:width]
        try:
            rows.append([float(c) if c.strip() else np.nan for c in cells])
        except ValueError:
            raise IPFError(f"line {lineno}: non-numeric TRC value", path) from None
    if len(rows) != n_frames:
        raise IPFError(f"TRC truncated or inconsistent: header says {n_frames} frames, "
                       f"found {len(rows)} data rows", path)
    table = np.array(rows)
    if np.isnan(table[:, 1]).any():
        raise IPFError("TRC Time column has empty cells (truncated row?)", path)
    # Writers keep every tab of an empty marker, so a short last row means the file was cut.
    if len(counts) > 1 and counts[-1] < min(counts[:-1]):
        raise IPFError(f"the last TRC row has {counts[-1]} fields, the others at least "
                       f"{min(counts[:-1])} (file truncated)", path)
    markers = {n: table[:, 2 + 3 * i: 5 + 3 * i] for i, n in enumerate(names)}
    units = header.get("Units", "").lower() or None
    return MarkerData(table[:, 1], markers, units, rate, None)


# --------------------------------------------------------------------------------------------------
# C3D


def read_c3d(path: str | Path) -> MarkerData:
    """Read a ``.c3d`` file with ezc3d: labels, ``POINT:RATE``, ``POINT:UNITS``, first frame.

    Time of stored frame ``i`` is ``(first_frame + i) / rate`` with ezc3d's 0-based first frame,
    so events stay on the clock of analog data (force plates) in the same file.
    """
    import ezc3d

    path = Path(path)
    try:
        c3d = ezc3d.c3d(str(path))
    except Exception as e:  # ezc3d raises plain RuntimeError/IOError on any damage
        raise IPFError(f"cannot read C3D ({e})", path) from None
    params = c3d["parameters"]["POINT"]
    labels = [str(s).strip() for s in params["LABELS"]["value"]]
    rate = float(c3d["header"]["points"]["frame_rate"])
    first = int(c3d["header"]["points"]["first_frame"])
    data = np.asarray(c3d["data"]["points"], dtype=float)              # (4, M, T)
    if rate <= 0 or data.shape[2] < 2 or not labels:
        raise IPFError("C3D has no point data (rate, labels or frames missing)", path)
    residuals = np.asarray(c3d["data"]["meta_points"]["residuals"])    # (1, M, T)
    xyz = data[:3].transpose(1, 2, 0).copy()                           # (M, T, 3)
    # C3D flags an unreconstructed marker with a negative residual; ezc3d keeps its zeros.
    xyz[residuals[0] < 0] = np.nan
    units_param = params.get("UNITS", {}).get("value") or [None]
    units = str(units_param[0]).strip().lower() if units_param[0] else None
    screen = params.get("Y_SCREEN", {}).get("value") or [None]
    up_axis = str(screen[0]).strip().lower() if screen[0] else None
    up_axis = up_axis if up_axis in AXES else None
    time = (first + np.arange(data.shape[2])) / rate
    markers = {name: xyz[i] for i, name in enumerate(labels[:xyz.shape[0]])}
    return MarkerData(time, markers, units, rate, up_axis)
