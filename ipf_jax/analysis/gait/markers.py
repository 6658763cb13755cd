"""Marker files (``.trc``, ``.c3d``) -> body points: marker set, units and up axis.

Without a marker map the marker set is recognised from the labels (:mod:`.markersets`: Plug-in
Gait, Helen Hayes, the Qualisys set of ``gait_trials``, Davis, OpenSim Rajagopal, ipf-jax's own
19 names); a file matching none is one error listing its markers and how to write a map.

A marker map is JSON, either ``{"roles": {role: marker | [markers]}}`` (optionally with ``name``
and ``description``) or the bare ``{role: marker | [markers]}`` object. Roles are the 19 body
point names and ``pelvis`` (a pelvis reference used when the sacrum has no data). A list is
averaged per frame. Every marker a map names must exist in the file; a role whose markers never
hold data is dropped with a note (the analysis then uses its stand-in, e.g. pelvis for sacrum).

Units: ``--units``, else the file's (TRC ``Units``, C3D ``POINT:UNITS``), else inferred from the
pelvis height; a stated unit that makes the pelvis height implausible is an error. Up axis:
``--up``, else the body's (:mod:`.vertical`); the file's hint (C3D ``POINT:Y_SCREEN``) is used
only when the body cannot tell, then ``+y`` (the lab and OpenSim convention).
"""
from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from ...errors import IPFError, IPFWarning, load_json
from ...geometry.world import axis_vector
from .c3d import read_c3d
from .markerdata import MarkerData
from .markersets import MARKER_SETS, index_labels, label_key, recognise, resolve
from .trajectories import ROLES, UNIT_SCALE, Trajectories, make_trajectories
from .trc import read_trc
from .vertical import PELVIS_HEIGHT_M, infer_unit, infer_up, pelvis_height, warn_if_contradicted

__all__ = [
    "MarkerData",
    "apply_marker_map",
    "load_marker_map",
    "read_c3d",
    "read_marker_file",
    "read_trc",
]


def read_marker_file(path: str | Path, *, marker_map: str | Path | None = None,
                     up: str | None = None, units: str | None = None,
                     cameras: int | None = None) -> Trajectories:
    """Read a ``.trc``/``.c3d`` file and turn its markers into body points (see module docs)."""
    path = Path(path)
    raw = read_c3d(path) if path.suffix.lower() == ".c3d" else read_trc(path)
    if marker_map is not None:
        map_path = Path(marker_map)
        points, notes = apply_marker_map(raw.markers, load_marker_map(map_path), data_path=path,
                                         map_path=map_path)
        notes = [f"marker map {map_path.name}", *notes]
    else:
        mset, points, _used, found = recognise(raw.markers)
        if mset is None:
            raise IPFError(_unrecognised(raw.markers), path)
        notes = [f"marker set recognised: {mset.name}", *found]
    if not points:
        raise IPFError("no marker of the map holds data", path)
    up_axis, up_note = _up_axis(points, up, raw, path)
    unit, unit_note = _unit(points, axis_vector(up_axis), units, raw, path)
    scale = UNIT_SCALE[unit]
    points = {k: v * scale for k, v in points.items()}
    notes = [*notes, *raw.notes, unit_note, up_note]
    return make_trajectories(raw.time, points, up_axis=up_axis, source=path, fps=raw.rate,
                             notes=tuple(notes), cameras=cameras)


def _up_axis(points: dict, up: str | None, raw: MarkerData, path: Path) -> tuple[str, str]:
    if up:
        warn_if_contradicted(points, up, path.name)
        return up, f"up axis {up} from --up"
    body, why = infer_up(points)
    if body is not None:
        extra = ""
        if raw.up_axis and raw.up_axis != body:
            extra = f" (the file's POINT:Y_SCREEN says {raw.up_axis}, a viewing hint: ignored)"
        return body, f"up axis {body} from the body: {why}{extra}"
    if raw.up_axis:
        return raw.up_axis, f"up axis {raw.up_axis} from the file's POINT:Y_SCREEN ({why})"
    return "+y", f"up axis +y assumed (lab convention; {why}): give --up if wrong"


def _unit(points: dict, up: np.ndarray, units: str | None, raw: MarkerData,
          path: Path) -> tuple[str, str]:
    height = pelvis_height(points, up)
    if units:
        if units not in UNIT_SCALE:
            raise IPFError(f"unknown units {units!r} (choose {', '.join(UNIT_SCALE)})", path)
        guess = None if height is None else infer_unit(height, UNIT_SCALE)
        if guess not in (None, units):  # like --up: said, the given unit kept
            warnings.warn(IPFWarning(
                f"{path.name}: --units {units} puts the pelvis {height * UNIT_SCALE[units]:.3g} m above "
                f"the feet ({guess} would make it {height * UNIT_SCALE[guess]:.2f} m): is the unit {guess}?"))
        return units, f"units {units} from --units"
    if raw.units:
        if height is not None and not (PELVIS_HEIGHT_M[0] <= height * UNIT_SCALE[raw.units]
                                       <= PELVIS_HEIGHT_M[1]):
            guess = infer_unit(height, UNIT_SCALE)
            said = (f"the file says its units are {raw.units}, which puts the pelvis "
                    f"{height * UNIT_SCALE[raw.units]:.3g} m above the feet")
            if guess:  # another unit fits the body: the Units field is wrong
                raise IPFError(f"{said} ({guess} would make it {height * UNIT_SCALE[guess]:.2f} "
                               "m): give --units", path)
            return raw.units, f"units {raw.units} from the file ({said}: check the markers)"
        return raw.units, f"units {raw.units} from the file"
    if height is None:
        raise IPFError("the file does not state its units and has no pelvis and foot markers to "
                       "infer them: give --units m, cm or mm", path)
    guess = infer_unit(height, UNIT_SCALE)
    if guess is None:
        raise IPFError(f"the file does not state its units, and no unit puts the pelvis "
                       f"({height:.3g} units above the feet) at a plausible height: give --units",
                       path)
    return guess, (f"units {guess} inferred (the file states none): the pelvis is "
                   f"{height * UNIT_SCALE[guess]:.2f} m above the feet")


def _unrecognised(markers: dict) -> str:
    labels = sorted(markers)
    shown = ", ".join(labels[:40]) + (f", ... ({len(labels)} in all)" if len(labels) > 40
                                      else "")
    sets = "; ".join(s.name for s in MARKER_SETS)
    return (f"no known marker set found (tried: {sets}); the file has: {shown}. Give a marker "
            'map with --marker-map FILE.json, e.g. {"roles": {"sacrum": ["LPSI", "RPSI"], '
            '"left_heel": "LHEE", "right_heel": "RHEE", "left_toe": "LTOE", '
            '"right_toe": "RTOE"}}')


# --------------------------------------------------------------------------------------------------
# Marker maps


def load_marker_map(path: str | Path) -> dict:
    """Read a marker map JSON -> ``{role: (marker, ...)}`` with every role a known role."""
    path = Path(path)
    doc = load_json(path, "marker map")
    roles = doc.get("roles", doc) if isinstance(doc, dict) else None
    if not isinstance(roles, dict) or not roles:
        raise IPFError("marker map must be a JSON object of role -> marker name(s)", path)
    if "roles" not in doc:
        roles = {k: v for k, v in roles.items() if k not in ("name", "description")}
    out = {}
    for role, names in roles.items():
        if role not in ROLES:
            raise IPFError(f"marker map role {role!r} is not a body point "
                           f"(known: {', '.join(ROLES)})", path)
        names = [names] if isinstance(names, str) else names
        if (not isinstance(names, list) or not names
                or not all(isinstance(n, str) and n for n in names)):
            raise IPFError(f"marker map role {role!r} must be a marker name or a non-empty list "
                           "of names", path)
        out[role] = tuple(names)
    return out


def apply_marker_map(markers: dict, roles: dict, *, data_path: str | Path,
                     map_path: str | Path) -> tuple[dict, list]:
    """Body points from markers: role -> (T, 3) (averaged lists), plus notes.

    Labels match exactly or after :func:`~.markersets.label_key` (case, separators, a
    ``Subject:`` prefix). Every marker the map names must exist in the file, otherwise
    :class:`IPFError` lists the missing ones: a map that silently drops a foot would give wrong
    gait events. A role whose markers never hold data is left out (noted).
    """
    index = index_labels(markers)
    missing = [f"{role} -> {n}" for role, names in roles.items() for n in names
               if n not in markers and label_key(n) not in index]
    if missing:
        have = ", ".join(sorted(markers)[:60])
        raise IPFError(f"marker map {Path(map_path).name} names markers the file does not have: "
                       f"{'; '.join(missing)} (the file has: {have}); fix the map or pass "
                       "another --marker-map", data_path)
    points, _used, notes = resolve(markers, {role: (names,) for role, names in roles.items()})
    return points, notes
