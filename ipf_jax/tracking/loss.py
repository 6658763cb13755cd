"""The absolute loss test: does the estimate still explain what the cameras see?

The relative confidence of :mod:`.tracker` (best weight over its recent median) sinks with the
track when the body drifts away slowly, so it never fires. This test does not drift: per camera,
on the estimate's own pixel counts (:mod:`ipf_jax.likelihood.scorer`),

* ``explained = Nc / (Nc + Ns)``: the share of the silhouette the model covers;
* ``covered = Nc / (Nc + Nm)``: the share of the model that lies on the silhouette.

A frame *fails* when, in the camera where it is lowest, either share falls below its level
(:data:`LEVELS`). A track whose frames keep failing is lost: the tracker tries a recovery
(:mod:`.recovery`) and, when that does not bring the shares back, declares the frame ``lost``.

The levels were calibrated with ``benchmarks/loss_levels.py`` on the default runs of the visible
4-camera renders (``../shared/data/mocap_walk_render``: the ten walks, clean and noisy, and the
four sit-to-stand sets, tracked by ``main`` at 29413d0): every frame's estimate was scored again
and its lowest per-camera shares compared with its mean 12-joint error. Each level is the 0.5th
percentile of the well-tracked frames' (error < 100 mm) shares, rounded down to 0.05::

    share       frames              p0.5   p1     p5     p25    p50
    explained   good (< 100 mm) 394  0.625  0.632  0.657  0.736  0.782
    explained   lost (> 200 mm) 136  0.469  0.485  0.523  0.563  0.596
    covered     good (< 100 mm) 394  0.726  0.742  0.772  0.837  0.878
    covered     lost (> 200 mm) 136  0.636  0.643  0.662  0.744  0.783

    python benchmarks/loss_levels.py RUNS   (RUNS: accuracy.py's OUT/runs of those sets)

At explained 0.60 and covered 0.70 none of the 394 well-tracked frames fails and 74 of the 136
lost ones do (the others are mostly a body turned round or with its legs swapped, which the
silhouettes cannot show). Every walk frame passes, so the test leaves walking runs alone.

**Clutter in a silhouette.** Something that is not the person but stays in a camera's silhouette
(the chair of a seated person, a bag, a cast shadow) lowers that camera's explained share on every
frame, however well the body fits: on the real Utrecht clip of a seated person the chair leaves
0.49-0.51 of camera 3's silhouette explained by a body that lies on it (covered 0.96) and fits
all four views. So each camera's explained level is taken relative to the first frame: where the
initial estimate lies on the silhouette (covered >= :data:`CLUTTER_COVERED`), the camera's level
is at most its first explained share less :data:`CLUTTER_MARGIN`, never below
:data:`CLUTTER_FLOOR` (:func:`clutter_levels`). A start that explains ``>= 0.70`` (every visible
walk) leaves the level as it is. The levels are set once, on the first frame, for the whole run.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..errors import require


class LossLevels(NamedTuple):
    """Lowest acceptable shares, per camera (see module doc); ``explained`` may be one level per
    camera (:func:`clutter_levels`)."""

    explained: float | tuple[float, ...] = 0.60
    covered: float = 0.70


LEVELS = LossLevels()
PATIENCE = 2  # failing frames in a row before the track counts as lost
CLUTTER_COVERED = 0.85  # the first estimate lies on the silhouette at least this much...
CLUTTER_MARGIN = 0.10  # ...then a camera's explained level is at most its first share less this
CLUTTER_FLOOR = 0.30  # but never below this (a first mask blown out by light keeps a test)


class Coverage(NamedTuple):
    """Per-camera shares of one pose: explained (C,), covered (C,); NaN for inactive cameras."""

    explained: np.ndarray
    covered: np.ndarray

    def lowest(self) -> tuple[float, float]:
        """(explained, covered) in the camera where each is lowest (NaN when no camera)."""
        e, c = self.explained[np.isfinite(self.explained)], self.covered[np.isfinite(self.covered)]
        return (float(e.min()) if e.size else np.nan), (float(c.min()) if c.size else np.nan)

    def to_json(self) -> dict:
        r = lambda v: [None if not np.isfinite(x) else round(float(x), 4) for x in v]  # noqa: E731
        return {"explained": r(self.explained), "covered": r(self.covered)}


def coverage(counts: np.ndarray, active: np.ndarray) -> Coverage:
    """(C, 3) counts (Nc, Ns, Nm) of one pose and (C,) active cameras -> its :class:`Coverage`."""
    counts = np.asarray(counts, np.float64)
    nc, ns, nm = counts[:, 0], counts[:, 1], counts[:, 2]
    explained = np.where(active, nc / np.maximum(nc + ns, 1.0), np.nan)
    covered = np.where(active, nc / np.maximum(nc + nm, 1.0), np.nan)
    return Coverage(explained, covered)


def fails(cov: Coverage, levels: LossLevels = LEVELS) -> bool:
    """True when some camera's explained or covered share is below its level (inactive cameras,
    NaN, never fail)."""
    explained = np.asarray(levels.explained, np.float64)
    require(explained.ndim == 0 or explained.shape == cov.explained.shape,
            f"loss levels for {explained.size} cameras, the frame has {cov.explained.size}")
    return bool(np.any(cov.explained < explained) or np.any(cov.covered < levels.covered))


def clutter_levels(first: Coverage, levels: LossLevels = LEVELS) -> LossLevels:
    """``levels`` with a per-camera explained level: at most the first frame's explained share
    less :data:`CLUTTER_MARGIN` (never below :data:`CLUTTER_FLOOR`) in each camera where the
    first estimate lies on the silhouette (covered >= :data:`CLUTTER_COVERED`); see the module
    doc."""
    base = np.broadcast_to(np.asarray(levels.explained, np.float64), first.explained.shape)
    clean = np.isfinite(first.explained) & (first.covered >= CLUTTER_COVERED)
    lowered = np.maximum(CLUTTER_FLOOR, first.explained - CLUTTER_MARGIN)
    explained = np.where(clean, np.minimum(base, lowered), base)
    return levels._replace(explained=tuple(round(float(v), 4) for v in explained))


def better(a: Coverage, b: Coverage) -> bool:
    """Whether ``a`` explains the silhouettes better than ``b``: a higher sum of the lowest
    explained and covered shares (the quantities the test is made of)."""
    return float(np.nansum(a.lowest())) > float(np.nansum(b.lowest()))
