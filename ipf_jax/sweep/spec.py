"""One unit of work (a sweep cell or a batch item): its settings, their types, and its stable id.

A *spec* is a JSON-serialisable dict, the same on every machine that runs it::

    {"dataset": abs path, "name": str, "truth": abs path | None, "init_pose": abs path | None,
     "frames": "A:B[:S]" | None, "filter": "ipf" | "apf" | "sir", "options": {filter options},
     "track": {other TrackSettings fields}, "eval": {"joints": [...] | None, "align": "none"}}

The id is ``<name>-<filter>-<12 hex>``: the dataset's name and the filter for people, then a
SHA-256 of the canonical JSON of everything that can change the result (paths, frames, filter
options, tracker settings, evaluation), so a rerun finds the cells it already finished and a
changed setting is a new cell.
"""
from __future__ import annotations

import hashlib
import json
import re
from pathlib import Path
from typing import NamedTuple

from ..body.limits import PRESETS
from ..data.frames import parse_frames
from ..errors import IPFError, require

SCHEMA = 1  # bump when the meaning of a spec changes, so old cells are not reused

#: Filter options (``TrackSettings.filter_options``) -> type.
OPTION_TYPES = {"top_m": int, "points_per_dof": int, "particles": int, "layers": int,
                "interval_width_deg": float, "max_speed_deg_s": float, "noise_scale": float,
                "survival": float, "interesting": "dofs"}
#: Other :class:`ipf_jax.tracking.tracker.TrackSettings` fields a spec may set -> type.
TRACK_TYPES = {"budget": int, "resolution": int, "seed": int, "chunk": int, "kernel": str,
               "limits": "limits", "height_m": float, "up_axis": str, "fps": float,
               "shape_file": "path", "confidence_drop": float, "confidence_patience": int,
               "origin_shift": bool, "floor_range": "range"}


class Cell(NamedTuple):
    id: str
    spec: dict
    label: str  # human description: dataset, filter and the values that vary


def coerce(key: str, value, *, base: Path, where: str, path=None):
    """``value`` checked against the type of ``key`` (ints stay ints, floats become floats)."""
    kind = OPTION_TYPES.get(key, TRACK_TYPES.get(key))
    bad = f"{where}: {key} must be "
    if kind is int:
        require(isinstance(value, int) and not isinstance(value, bool), bad + f"an integer (got {value!r})", path)
        return value
    if kind is float:
        require(isinstance(value, (int, float)) and not isinstance(value, bool),
                bad + f"a number (got {value!r})", path)
        return float(value)
    if kind is bool:
        require(isinstance(value, bool), bad + f"true or false (got {value!r})", path)
        return value
    if kind == "range":
        require(isinstance(value, (list, tuple)) and len(value) == 2
                and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value)
                and value[0] <= value[1], bad + f"[low, high] in metres, low <= high (got {value!r})", path)
        return [float(v) for v in value]
    if kind == "dofs":
        require(isinstance(value, list) and value and all(isinstance(v, str) for v in value),
                bad + f"a list of DOF names (got {value!r})", path)
        return list(value)
    require(isinstance(value, str) and value != "", bad + f"a string (got {value!r})", path)
    if kind == "path" or (kind == "limits" and value not in PRESETS):
        return str(resolve(value, base))
    return value


def resolve(value: str, base: Path) -> Path:
    """A path from a config or manifest: ``~`` and ``$VARS`` expanded, relative to ``base``."""
    import os

    p = Path(os.path.expandvars(os.path.expanduser(value)))
    return (p if p.is_absolute() else base / p).resolve()


def check_frames(value, *, where: str, path=None) -> str:
    require(isinstance(value, str), f"{where}: frames must be a string like \"0:12\" or "
            f"\"0:32:2\" (got {value!r})", path)
    parse_frames(value, f"{where}: frames", path)
    return value.replace(" ", "")


def cell_id(spec: dict) -> str:
    keep = {k: spec[k] for k in ("dataset", "truth", "init_pose", "frames", "filter", "options",
                                 "track", "eval")}
    digest = hashlib.sha256(json.dumps([SCHEMA, keep], sort_keys=True).encode()).hexdigest()[:12]
    name = re.sub(r"[^A-Za-z0-9._-]+", "_", spec["name"]).strip("_") or "data"
    return f"{name}-{spec['filter']}-{digest}"


def make_cell(spec: dict, varying: dict | None = None) -> Cell:
    shown = " ".join(f"{k}={v}" for k, v in (varying or {}).items())
    return Cell(cell_id(spec), spec, f"{spec['name']} {spec['filter']}" + (f" {shown}" if shown else ""))


def track_settings(spec: dict):
    """The :class:`ipf_jax.tracking.tracker.TrackSettings` of a spec (initial pose read from its file)."""
    from ..data.runfiles import read_pose_rows
    from ..tracking.tracker import TrackSettings

    track = dict(spec["track"])
    options = dict(spec["options"])
    if "interesting" in options:
        options["interesting"] = tuple(options["interesting"])
    if track.get("floor_range") is not None:
        track["floor_range"] = tuple(track["floor_range"])
    init_pose = read_pose_rows(spec["init_pose"])[0] if spec.get("init_pose") else None
    return TrackSettings(filter=spec["filter"], filter_options=options, init_pose=init_pose, **track)


def check_filter(spec: dict, *, where: str, path=None) -> None:
    """Build the spec's filter once (cheap) so impossible options fail before any tracking."""
    from ..body.limits import load_limits
    from ..filters import registry
    from ..tracking.tracker import DEFAULT_FPS

    options = dict(spec["options"])
    if "interesting" in options:
        options["interesting"] = tuple(options["interesting"])
    try:
        registry.make(spec["filter"], options, load_limits(spec["track"].get("limits", "default")),
                      spec["track"].get("fps") or DEFAULT_FPS, budget=spec["track"].get("budget"))
    except IPFError as e:
        raise IPFError(f"{where}: {e}", path) from None
