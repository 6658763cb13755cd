"""Condensation / SIR (Isard & Blake 1998): resample by weight, diffuse every DOF, weigh.

Per frame: draw N particles from the previous weighted set by systematic resampling (the
factored sampling step), move each with the dynamical model, here a random walk of independent
Gaussian noise on all 31 DOF (:func:`~ipf_jax.filters.base.default_noise_rates` x 1/fps, the same
rates IPF uses for its R sub-vector), clip to the limits, and weigh with the likelihood. The
weights are the likelihood itself (Condensation has no tempering: that is what APF adds).

Estimates: the heaviest particle (``FilterInfo.best``, what the tracker writes, as for IPF) and the
weighted mean (``FilterInfo.mean``, Condensation's own estimate of the posterior mean).
"""
from __future__ import annotations

from typing import NamedTuple

import jax
import numpy as np

from ..body.limits import Limits
from ..body.model import NUM_DOF
from ..errors import require
from .base import (
    Filter,
    FilterState,
    default_noise_rates,
    init_state,
    moved,
    rate_std,
    resample_diffuse,
    resample_draws,
    summarise,
)


class SIRSettings(NamedTuple):
    particles: int = 6561  # IPF's default cost (81 x 81 evaluations per frame)
    noise_scale: float = 1.0  # multiplies the default per-DOF noise rates


def validate(settings: SIRSettings) -> None:
    require(settings.particles >= 1, f"SIR needs at least one particle (got {settings.particles})")
    require(0 <= settings.noise_scale < np.inf,
            f"noise scale must be >= 0 and finite (got {settings.noise_scale})")


def build(settings: SIRSettings, limits: Limits, fps: float) -> Filter:
    """The SIR kernel for fixed settings: exactly ``particles`` evaluations per frame."""
    validate(settings)
    std = rate_std(default_noise_rates(), fps) * settings.noise_scale  # (D,)
    n = settings.particles

    def draws(rng_key: jax.Array) -> tuple:
        return resample_draws(rng_key, (n, NUM_DOF))

    def step(rng_key: jax.Array, state: FilterState, measure, drawn: tuple | None = None,
             shift: np.ndarray | None = None):
        state = moved(state, shift)
        drawn = drawn if drawn is not None and drawn[1].shape == (n, NUM_DOF) else None
        new = resample_diffuse(rng_key, state.particles, state.weights, std, limits, n, drawn)  # (N, D)
        weights = np.asarray(measure(new), float)
        return FilterState(new, weights), summarise(new, weights, n)

    return Filter("sir", init_state, step, n, {"particles": n, "noise_scale": settings.noise_scale}, (n,),
                  draws)
