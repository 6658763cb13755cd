"""Subject shape: segment lengths, joint offsets and capsule radii (metres).

A shape file is JSON ``{"height_m": H, "params": {name: metres, ...}}`` with every name of
:data:`ipf_jax.body.model.SHAPE_PARAM_NAMES` (other keys, e.g. ``"source"`` or a fit's
``"fit"`` record, are ignored); each parameter's ratio to the body's standing height must lie
within the anthropometric bounds of :mod:`ipf_jax.body.proportions`. The default adult (``presets/shape_default.json``) is
1.75 m tall; :meth:`BodyShape.scaled_to` scales every length and radius uniformly to another height.
"""
from __future__ import annotations

import warnings
from pathlib import Path
from typing import NamedTuple

import numpy as np

from ..errors import IPFError, IPFWarning, load_json, require
from .model import LEGACY_PARAMS, SHAPE_INDEX, SHAPE_PARAM_NAMES
from .proportions import check_bounds, stature

PRESET_DIR = Path(__file__).parent / "presets"

#: Bone lengths that vary together between people (used to fit a subject's proportions).
LENGTH_GROUPS = {"legs": ("thigh", "shank"), "arms": ("upper_arm", "forearm"), "trunk": ("trunk",)}


class BodyShape(NamedTuple):
    """Subject shape.

    values : (P,) float array, metres, in :data:`SHAPE_PARAM_NAMES` order.
    height_m : standing height the values correspond to.
    """

    values: np.ndarray
    height_m: float

    def __getitem__(self, key):  # type: ignore[override]
        if isinstance(key, str):
            return float(self.values[SHAPE_INDEX[key]])
        return tuple.__getitem__(self, key)

    def scaled_to(self, height_m: float) -> "BodyShape":
        """The same proportions at another standing height."""
        require(np.isfinite(height_m) and 0.5 <= height_m <= 2.6,
                f"height {height_m} m is outside 0.5..2.6 m")
        k = height_m / self.height_m
        return BodyShape(np.asarray(self.values, np.float64) * k, float(height_m))

    def with_factors(self, **factors: float) -> "BodyShape":
        """The same subject with some segment groups lengthened (``legs=1.04``, ``arms``, ``trunk``).

        Only bone lengths change; radii and the standing height label stay (the height is the
        label of the proportions the factors start from).
        """
        values = np.array(self.values, np.float64)
        for group, k in factors.items():
            require(group in LENGTH_GROUPS, f"unknown segment group {group!r}")
            require(0.5 < k < 1.5, f"segment factor {k} is outside 0.5..1.5")
            for name in LENGTH_GROUPS[group]:
                values[SHAPE_INDEX[name]] *= k
        return BodyShape(values, self.height_m)

    def to_json(self) -> dict:
        return {"height_m": self.height_m,
                "params": {n: float(v) for n, v in zip(SHAPE_PARAM_NAMES, self.values)}}


def load_shape(path: str | Path) -> BodyShape:
    """Read a shape file (see module docstring); raises :class:`IPFError` on any problem."""
    return shape_from_json(load_json(path, "shape file"), path)


def shape_from_json(doc: dict, path: str | Path | None = None) -> BodyShape:
    """A shape from its JSON document (``run.json``'s ``shape`` too); IPFError names ``path``."""
    require(isinstance(doc, dict) and isinstance(doc.get("params"), dict),
            "shape file needs a 'params' object", path)
    params = with_legacy_params(doc["params"], path)
    missing = [n for n in SHAPE_PARAM_NAMES if n not in params]
    require(not missing, f"shape file misses parameters: {', '.join(missing)}", path)
    unknown = sorted(set(params) - set(SHAPE_PARAM_NAMES))
    require(not unknown, f"unknown shape parameters: {', '.join(map(repr, unknown))}", path)
    try:
        values = np.array([float(params[n]) for n in SHAPE_PARAM_NAMES])
        height = None if doc.get("height_m") is None else float(doc["height_m"])
    except (TypeError, ValueError):
        raise IPFError("shape parameters must be numbers (metres)", path) from None
    require(bool(np.all(np.isfinite(values))), "shape parameters must be finite", path)
    radii = [i for n, i in SHAPE_INDEX.items() if n.endswith(("_r", "_r0", "_r1", "_r_low", "_r_high"))]
    require(bool(np.all(values[radii] > 0)), "capsule radii must be positive", path)
    lengths = [SHAPE_INDEX[n] for n in ("thigh", "shank", "trunk", "upper_arm", "forearm", "neck")]
    require(bool(np.all(values[lengths] > 0)), "segment lengths must be positive", path)
    if height is None:  # left out: the body's own standing height (proportions doc)
        height = float(stature(values))
    require(0.5 <= height <= 2.6, f"height_m {height} is outside 0.5..2.6 m", path)
    check_bounds(values, path)  # anthropometric ratios (ipf_jax.body.proportions)
    return BodyShape(values, height)


def with_legacy_params(params: dict, path: str | Path | None = None, warn: bool = True) -> dict:
    """``params`` as the current model reads them, for a file written before some parameters:
    those it lacks get the values that keep its body as it was (:data:`LEGACY_PARAMS`), and
    ``pelvis_up`` (the pelvis capsule's axis over the hips) becomes ``crotch_depth = pelvis_r -
    pelvis_up``; one warning names what was done."""
    params, notes = dict(params), []
    if "pelvis_up" in params and "crotch_depth" not in params and "pelvis_r" in params:
        try:
            params["crotch_depth"] = float(params["pelvis_r"]) - float(params.pop("pelvis_up"))
        except (TypeError, ValueError):
            raise IPFError("shape parameters must be numbers (metres)", path) from None
        notes.append("pelvis_up read as crotch_depth = pelvis_r - pelvis_up")
    added = {n: v for n, v in LEGACY_PARAMS.items() if n not in params}
    if added:
        notes.append(f"written before {', '.join(added)}: "
                     f"{', '.join(f'{n} = {v:g}' for n, v in added.items())}")
    if notes and warn:
        where = f"{path}: " if path is not None else ""
        warnings.warn(f"{where}an older shape ({'; '.join(notes)}) keeps its body as it was "
                      "(refit for the current model)", IPFWarning, stacklevel=3)
    return {**added, **params}


def default_shape(height_m: float | None = None) -> BodyShape:
    """The default adult (1.75 m), optionally scaled to ``height_m``."""
    shape = load_shape(PRESET_DIR / "shape_default.json")
    return shape if height_m is None else shape.scaled_to(height_m)
