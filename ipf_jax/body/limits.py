"""Per-DOF [min, max] ranges.

A limits file is JSON ``{"name", "source", "dofs": {dof_name: [min, max]}}``: angles in **degrees**,
root translations in metres (``null`` = unbounded). Every DOF must be listed. Presets ship in
``presets/limits_<name>.json``: ``default`` (physiological ranges of motion) and ``walking`` (the
paper's tighter ranges). ``root_yaw`` is periodic: it is wrapped, not clipped.
"""
from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

import numpy as np

from ..errors import IPFError, load_json, require
from .model import DOF_INDEX, DOF_NAMES, DOFS, NUM_DOF, PERIODIC_DOFS

PRESET_DIR = Path(__file__).parent / "presets"
PRESETS = ("default", "walking")
_UNBOUNDED = 1e3  # metres: stands for "no limit" on root translation


class Limits(NamedTuple):
    """lower, upper : (D,) float64 arrays, radians / metres."""

    lower: np.ndarray
    upper: np.ndarray
    name: str

    def wrap(self, x: np.ndarray, *, copy: bool = True) -> np.ndarray:
        """(..., D) states with the periodic DOFs wrapped to [-pi, pi), nothing clipped
        (``copy=False``: in place when ``x`` is a float64 array)."""
        x = np.array(x, dtype=float, copy=copy or None)
        for i in PERIODIC_DOFS:  # a heading of 190 deg is -170 deg, not 180
            col = x[..., i]  # in place, the same operations as (x + pi) % 2pi - pi
            col += np.pi
            np.mod(col, 2 * np.pi, out=col)
            col -= np.pi
        return x

    def outside(self, x: np.ndarray) -> np.ndarray:
        """(..., D) bool: the DOFs :meth:`clip` would move beyond wrapping (out of range)."""
        w = self.wrap(x)
        return (w < self.lower - 1e-9) | (w > self.upper + 1e-9)

    def clip(self, x: np.ndarray, *, copy: bool = True) -> np.ndarray:
        """Clip (..., D) states into range; wrap periodic DOFs to [-pi, pi). ``copy=False``: in
        place when ``x`` is a float64 array (a caller's fresh array: no copy of N x D)."""
        x = self.wrap(x, copy=copy)  # wrap first
        # x is ours: no second copy; np.maximum / np.minimum give np.clip's numbers (NaN kept)
        # in 2/3 of its time on 6561 x 31 states
        np.maximum(x, self.lower, out=x)
        return np.minimum(x, self.upper, out=x)

    def width(self) -> np.ndarray:
        return self.upper - self.lower


def load_limits(preset_or_path: str | Path = "default") -> Limits:
    """Load a preset by name (``default``, ``walking``) or a limits JSON file."""
    p = str(preset_or_path)
    path = PRESET_DIR / f"limits_{p}.json" if p in PRESETS else Path(p)
    doc = load_json(path, "limits file", missing_hint=f" (presets: {', '.join(PRESETS)})")
    dofs = doc.get("dofs") if isinstance(doc, dict) else None
    require(isinstance(dofs, dict), "limits file needs a 'dofs' object", path)
    missing = [n for n in DOF_NAMES if n not in dofs]
    require(not missing, f"limits file misses DOFs: {', '.join(missing)}", path)
    unknown = sorted(set(dofs) - set(DOF_NAMES))
    require(not unknown, f"unknown DOFs in limits file: {', '.join(map(repr, unknown))}", path)
    lower = np.empty(NUM_DOF)
    upper = np.empty(NUM_DOF)
    for d in DOFS:
        rng = dofs[d.name]
        require(isinstance(rng, list) and len(rng) == 2, f"{d.name}: range must be [min, max]", path)
        require(d.unit != "rad" or None not in rng, f"{d.name}: an angle's range needs both ends "
                "(null = unbounded is for the root's translation)", path)
        lo, hi = (-_UNBOUNDED if rng[0] is None else rng[0]), (_UNBOUNDED if rng[1] is None else rng[1])
        require(not isinstance(lo, bool) and not isinstance(hi, bool),
                f"{d.name}: range values must be numbers (got {rng!r})", path)
        try:
            lo, hi = float(lo), float(hi)
        except (TypeError, ValueError):
            raise IPFError(f"{d.name}: range values must be numbers", path) from None
        require(np.isfinite(lo) and np.isfinite(hi), f"{d.name}: range must be finite", path)
        require(lo <= hi, f"{d.name}: min {lo} > max {hi}", path)
        if d.unit == "rad":
            require(-360.0 <= lo and hi <= 360.0, f"{d.name}: [{lo:g}, {hi:g}] is not a range of "
                    "degrees (-360..360)", path)
            lo, hi = np.deg2rad(lo), np.deg2rad(hi)
        lower[DOF_INDEX[d.name]], upper[DOF_INDEX[d.name]] = lo, hi
    return Limits(lower, upper, str(doc.get("name", path.stem)))


def limits_to_json(limits: Limits) -> dict:
    out = {}
    for d, lo, hi in zip(DOFS, limits.lower, limits.upper):
        if d.unit == "rad":
            lo, hi = np.rad2deg(lo), np.rad2deg(hi)
        out[d.name] = [float(lo), float(hi)]
    return {"name": limits.name, "dofs": out}
