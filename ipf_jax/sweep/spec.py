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

from ..data.frames import parse_frames
from ..errors import IPFError, require
from ..paths import expand_path
from ..tracking.options import (
    BY_KEY,
    FILTER_KEYS,
    TRACK_KEYS,
    check_value,
    check_values,
    resolve_path,
    settings_from,
)

SCHEMA = 1  # bump when the meaning of a spec changes, so old cells are not reused

#: Filter options (``TrackSettings.filter_options``) and the other ``TrackSettings`` fields a spec
#: may set -> their kind; both from the one table of tracking options.
OPTION_TYPES = {k: BY_KEY[k].kind for k in FILTER_KEYS}
TRACK_TYPES = {k: BY_KEY[k].kind for k in TRACK_KEYS if k != "filter"}


class Cell(NamedTuple):
    id: str
    spec: dict
    label: str  # human description: dataset, filter and the values that vary


def coerce(key: str, value, *, base: Path, where: str, path=None):
    """``value`` checked against the kind of option ``key`` (ints stay ints, floats become floats)
    and its rule (:func:`ipf_jax.tracking.options.check_value`)."""
    kind = BY_KEY[key].kind
    bad = f"{where}: {key} must be "
    if kind == "int":
        require(isinstance(value, int) and not isinstance(value, bool), bad + f"an integer (got {value!r})", path)
    elif kind == "float":
        require(isinstance(value, (int, float)) and not isinstance(value, bool),
                bad + f"a number (got {value!r})", path)
        value = float(value)
    elif kind == "bool":
        require(isinstance(value, bool), bad + f"true or false (got {value!r})", path)
    elif kind == "range":
        require(isinstance(value, (list, tuple)) and len(value) == 2
                and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value)
                and value[0] <= value[1], bad + f"[low, high] in metres, low <= high (got {value!r})", path)
        value = [float(v) for v in value]
    elif kind == "dofs":
        require(isinstance(value, list) and value and all(isinstance(v, str) for v in value),
                bad + f"a list of DOF names (got {value!r})", path)
        value = list(value)
    else:
        require(isinstance(value, str) and value != "", bad + f"a string (got {value!r})", path)
        if kind in ("path", "limits"):
            value = resolve_path(value, base)
    check_value(key, value, f"{where}: {key}", path)
    return value


def resolve(value: str, base: Path) -> Path:
    """A path from a config or manifest, relative to ``base`` (:func:`ipf_jax.paths.expand_path`)."""
    return expand_path(value, base)


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
    """The :class:`ipf_jax.tracking.settings.TrackSettings` of a spec (initial pose read from its
    file)."""
    from ..data.runfiles import read_pose_rows

    init_pose = read_pose_rows(spec["init_pose"])[0] if spec.get("init_pose") else None
    return settings_from({**spec["options"], **spec["track"], "filter": spec["filter"]},
                         init_pose=init_pose)


def check_filter(spec: dict, *, where: str, path=None) -> None:
    """The spec's filter with its options and budget, checked (nothing is built) so impossible
    options fail before any tracking."""
    values = {**spec["options"], **spec["track"], "filter": spec["filter"]}
    try:
        check_values(values, name=lambda k: k)
    except IPFError as e:
        raise IPFError(f"{where}: {e.message}", path) from None
