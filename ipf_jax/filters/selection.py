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
    return np.argsort(-w, kind="stable")


def heaviest(weights: np.ndarray, num: int) -> np.ndarray:
    """The first ``num`` or more entries of :func:`stable_order` (all ties at the ``num``-th weight
    included), without sorting the rest: a partition finds the ``num``-th weight."""
    w = np.where(np.isnan(weights), -np.inf, weights)
    if num >= len(w):
        return np.argsort(-w, kind="stable")
    kth = np.partition(-w, num - 1)[num - 1]
    cand = np.flatnonzero(-w <= kth)  # ascending index: a stable sort keeps ties in order
    return cand[np.argsort(-w[cand], kind="stable")]


def _first_distinct(rows: np.ndarray) -> np.ndarray:
    """Positions of the first occurrence of each distinct row of finite (K, D) ``rows``, ascending.

    Rows are compared as bytes (one opaque item per row, not D float columns); ``+ 0.0`` turns
    -0.0 into 0.0 first, so byte equality is float equality for finite numbers.
    """
    packed = np.ascontiguousarray(rows + 0.0)
    items = packed.view(np.dtype((np.void, packed.dtype.itemsize * packed.shape[1]))).ravel()
    _, first = np.unique(items, return_index=True)
    return np.sort(first)


def top_distinct(particles: np.ndarray, weights: np.ndarray, num: int,
                 shift: np.ndarray | None = None) -> np.ndarray:
    """Indices of the ``num`` heaviest *distinct* particles (distinct = different state vector).

    If fewer distinct particles exist, the distinct ones are cycled in weight order so the
    result always has ``num`` entries (fixed shapes downstream).

    ``shift`` (D,): the particles are compared as ``particles + shift`` (two rows a shift rounds
    together are one), the indices those of ``top_distinct(particles + shift, ...)`` without
    shifting the whole set: only the rows examined are.

    Only a prefix of the weight order is examined: the heaviest ``k`` particles (``k = num``, then
    4x more while duplicates leave fewer than ``num`` distinct ones). The first occurrences within a
    prefix are the first occurrences in the whole order, so the result is that of deduplicating the
    whole sorted set. Rows are compared as bytes while the examined ones are finite; a NaN or an
    infinity among them sends the whole set to NumPy's float comparison of rows (the same result
    for finite rows, slower), so only the examined rows are checked.
    """
    particles = np.asarray(particles)
    moved = (lambda rows: rows) if shift is None else (lambda rows: rows + shift)
    k = max(int(num), 1)
    while True:
        cand = heaviest(weights, k)
        rows = moved(particles[cand])
        if not np.all(np.isfinite(rows)):
            return _top_distinct_any(moved(particles), weights, num)
        distinct = cand[_first_distinct(rows)]
        if len(distinct) >= num:
            return distinct[:num]
        if len(cand) >= len(particles):
            return np.resize(distinct, num)
        k *= 4


def _top_distinct_any(particles: np.ndarray, weights: np.ndarray, num: int) -> np.ndarray:
    """:func:`top_distinct` of rows that may hold NaN or infinities: NumPy's row comparison of
    the whole set in weight order."""
    order = stable_order(weights)
    _, first = np.unique(particles[order], axis=0, return_index=True)
    distinct = order[np.sort(first)]
    return distinct[:num] if len(distinct) >= num else np.resize(distinct, num)


def systematic(rng_key: jax.Array, weights: np.ndarray, num_samples: int) -> np.ndarray:
    """Systematic resampling: one uniform offset, ``num_samples`` evenly spaced pointers."""
    return systematic_at(float(jax.random.uniform(rng_key, ())), weights, num_samples)


def systematic_at(u: float, weights: np.ndarray, num_samples: int) -> np.ndarray:
    """:func:`systematic` with its uniform offset ``u`` in [0, 1) drawn already (by a caller that
    draws it with the noise in one compiled call)."""
    w = np.where(np.isfinite(weights), np.maximum(weights, 0.0), 0.0)
    if w.sum() <= 0:
        w = np.ones_like(w)
    cdf = np.cumsum(w / w.sum())
    cdf[-1] = 1.0
    pointers = (u + np.arange(num_samples)) / num_samples
    return np.searchsorted(cdf, pointers, side="right").clip(0, len(w) - 1)
