"""Particle filters on the silhouette likelihood, as siblings with one interface (blackjax style).

Each module exposes ``build(settings, limits, fps, ...) -> Filter``: a pure ``init`` and a
``step(rng_key, state, measure) -> (state, info)``; ``measure(particles (N, D)) -> weights (N,)`` is
the frame's likelihood (the tracker closes it over the observation). The host does selection and
sorting in NumPy; the likelihood is the jitted scorer.
"""
from .base import Filter, FilterInfo, FilterState

__all__ = ["Filter", "FilterInfo", "FilterState"]
