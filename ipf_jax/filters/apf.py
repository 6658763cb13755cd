"""Annealed particle filter (Deutscher & Reid 2005): L layers of weigh -> anneal -> resample.

Per frame and layer: diffuse (noise shrinking layer by layer), weigh with the likelihood, raise
the weights to the power beta chosen so that a target fraction of the particles survives (the
effective sample fraction (sum w)^2 / (N sum w^2), default 0.5, as bodytrack), resample. The
estimate is the heaviest particle of the last layer (the weighted mean is recorded too).
"""
from __future__ import annotations

from typing import NamedTuple

import jax
import numpy as np

from ..body.limits import Limits
from ..errors import require
from .base import Filter, FilterState, default_noise_rates, rate_std, resample_diffuse, summarise


class APFSettings(NamedTuple):
    particles: int = 4000
    layers: int = 5
    survival: float = 0.5  # target effective sample fraction per layer
    noise_scale: float = 1.0
    noise_decay: float = 0.5 ** 0.5  # noise std multiplier from one layer to the next


def effective_fraction(w: np.ndarray) -> float:
    """(sum w)^2 / (N sum w^2) of non-negative weights (1 = all equal, 1/N = one survivor)."""
    s2 = float(np.sum(w * w))
    return float(np.sum(w)) ** 2 / (len(w) * s2) if s2 > 0 else 0.0


def anneal_beta(likelihood: np.ndarray, target: float, *, iters: int = 60) -> float:
    """beta >= 0 with effective_fraction(likelihood ** beta) == target (bisection in log space)."""
    lw = np.log(np.where(likelihood > 0, likelihood, np.nan))
    ok = np.isfinite(lw)
    if ok.sum() <= 1:
        return 1.0
    lw = lw[ok] - np.max(lw[ok])

    def esf(beta):
        return effective_fraction(np.exp(beta * lw)) * ok.sum() / len(likelihood)

    if esf(0.0) <= target:
        return 0.0
    lo, hi = 0.0, 1.0
    while esf(hi) > target and hi < 1e6:
        lo, hi = hi, hi * 2
    for _ in range(iters):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if esf(mid) > target else (lo, mid)
    return 0.5 * (lo + hi)


def annealed_weights(likelihood: np.ndarray, target: float) -> np.ndarray:
    beta = anneal_beta(likelihood, target)
    lw = np.log(np.where(likelihood > 0, likelihood, np.nan))
    w = np.exp(beta * (lw - np.nanmax(lw)))
    return np.where(np.isfinite(w), w, 0.0)


def build(settings: APFSettings, limits: Limits, fps: float) -> Filter:
    require(settings.particles >= 1, f"APF needs at least one particle (got {settings.particles})")
    require(settings.layers >= 1, f"APF needs at least one layer (got {settings.layers})")
    require(0 < settings.survival < 1, f"survival fraction must be in (0, 1) (got {settings.survival})")
    require(settings.noise_scale >= 0, f"noise scale must be >= 0 (got {settings.noise_scale})")
    std = rate_std(default_noise_rates(), fps) * settings.noise_scale
    n, layers = settings.particles, settings.layers

    def init(particles, weights):
        return FilterState(np.asarray(particles, float), np.asarray(weights, float))

    def step(rng_key: jax.Array, state: FilterState, measure):
        x, pi = state.particles, annealed_weights(state.weights, settings.survival)
        for layer in range(layers):
            scale = settings.noise_decay ** layer
            x = resample_diffuse(jax.random.fold_in(rng_key, layer), x, pi, std * scale, limits, n)
            likelihood = np.asarray(measure(x), float)
            pi = annealed_weights(likelihood, settings.survival)
        info = summarise(x, likelihood, n * layers)
        info = info._replace(mean=(pi[:, None] * x).sum(0) / max(pi.sum(), 1e-300))
        # the next frame resamples by the annealed weights; report the raw likelihoods as weights
        return FilterState(x, likelihood), info

    return Filter("apf", init, step, n * layers,
                  {"particles": n, "layers": layers, "survival": settings.survival,
                   "noise_scale": settings.noise_scale, "noise_decay": settings.noise_decay})
