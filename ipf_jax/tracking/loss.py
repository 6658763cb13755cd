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
renders (``../shared/data/mocap_walk_render``: the five clean 4-camera walks and the four 4-camera
sit-to-stand sets, tracked by ``main`` at 29413d0): over frames whose mean 12-joint error is under
100 mm (well tracked) the lowest per-camera shares were taken, and each level sits below the
0.5th percentile of those frames' values (rounded down to 0.05), so a well-tracked frame fails
about once in 200 frames and :data:`PATIENCE` failing frames in a row are needed. The script's
table (good frames' percentiles against frames above 200 mm) is in ``benchmarks/README.md``.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np


class LossLevels(NamedTuple):
    """Lowest acceptable shares, per camera (see module doc)."""

    explained: float = 0.55
    covered: float = 0.55


LEVELS = LossLevels()
PATIENCE = 2  # failing frames in a row before the track counts as lost


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
    """True when some camera's explained or covered share is below its level."""
    e, c = cov.lowest()
    return bool((np.isfinite(e) and e < levels.explained) or (np.isfinite(c) and c < levels.covered))


def better(a: Coverage, b: Coverage) -> bool:
    """Whether ``a`` explains the silhouettes better than ``b``: a higher sum of the lowest
    explained and covered shares (the quantities the test is made of)."""
    return float(np.nansum(a.lowest())) > float(np.nansum(b.lowest()))
