"""Condensation / SIR (Isard & Blake): resample by weight, diffuse every DOF, weigh.

The estimate is the heaviest particle (as IPF); the weighted mean is recorded too. The same noise
rates as IPF's R sub-vector, scaled by 1/fps, diffuse all 31 DOF.
"""
from __future__ import annotations

from typing import NamedTuple

import jax
import numpy as np

from ..body.limits import Limits
from ..errors import require
from .base import Filter, FilterState, default_noise_rates, rate_std, resample_diffuse, summarise


class SIRSettings(NamedTuple):
    particles: int = 6561
    noise_scale: float = 1.0


def build(settings: SIRSettings, limits: Limits, fps: float) -> Filter:
    require(settings.particles >= 1, f"SIR needs at least one particle (got {settings.particles})")
    require(settings.noise_scale >= 0, f"noise scale must be >= 0 (got {settings.noise_scale})")
    std = rate_std(default_noise_rates(), fps) * settings.noise_scale
    n = settings.particles

    def init(particles, weights):
        return FilterState(np.asarray(particles, float), np.asarray(weights, float))

    def step(rng_key: jax.Array, state: FilterState, measure):
        new = resample_diffuse(rng_key, state.particles, state.weights, std, limits, n)
        weights = np.asarray(measure(new), float)
        return FilterState(new, weights), summarise(new, weights, n)

    return Filter("sir", init, step, n, {"particles": n, "noise_scale": settings.noise_scale})
