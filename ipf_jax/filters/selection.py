"""Selection functions with one signature style: (weights, ...) -> indices.

``top_distinct`` is IPF's deterministic selection; ``systematic`` is the stochastic resampler of
SIR/APF (``(rng_key, weights, num_samples) -> indices``, as blackjax's resamplers).
"""
from __future__ import annotations

import jax
import numpy as np


def stable_order(weights: np.ndarray) -> np.ndarray:
    """Indices sorted by (-w, index): heaviest first, ties by original position, NaN last."""
    w = np.where(np.isnan(weights), -np.inf, weights)
    return np.lexsort((np.arange(len(w)), -w))


def top_distinct(particles: np.ndarray, weights: np.ndarray, num: int) -> np.ndarray:
    """Indices of the ``num`` heaviest *distinct* particles (distinct = different state vector).

    If fewer distinct particles exist, the distinct ones are cycled in weight order so the
    result always has ``num`` entries (fixed shapes downstream).
    """
    order = stable_order(weights)
    _, first = np.unique(particles[order], axis=0, return_index=True)
    distinct = order[np.sort(first)]  # first occurrence of each state, in weight order
    if len(distinct) >= num:
        return distinct[:num]
    return np.resize(distinct, num)


def systematic(rng_key: jax.Array, weights: np.ndarray, num_samples: int) -> np.ndarray:
    """Systematic resampling: one uniform offset, ``num_samples`` evenly spaced pointers."""
    w = np.where(np.isfinite(weights), np.maximum(weights, 0.0), 0.0)
    if w.sum() <= 0:
        w = np.ones_like(w)
    cdf = np.cumsum(w / w.sum())
    cdf[-1] = 1.0
    u = float(jax.random.uniform(rng_key, ()))
    pointers = (u + np.arange(num_samples)) / num_samples
    return np.searchsorted(cdf, pointers, side="right").clip(0, len(w) - 1)
