"""Reference likelihood: FK -> projection -> full-image raster -> counts, one particle at a time."""
from __future__ import annotations

import numpy as np

from ..geometry.camera import Camera
from ..geometry.host import project_capsules
from ..likelihood.scorer import weights_from_counts
from .raster import counts_from_caps

__all__ = ["project_capsules", "counts", "weights_from_counts"]


def counts(particles, shape_values, up, cameras: list[Camera], masks: list[np.ndarray]) -> np.ndarray:
    """(N, D) particles -> (N, C, 3) int64 counts (Nc, Ns, Nm)."""
    particles = np.atleast_2d(np.asarray(particles, float))
    out = np.zeros((len(particles), len(cameras), 3), np.int64)
    for n, q in enumerate(particles):
        caps = project_capsules(q, shape_values, up, cameras)
        for c, mask in enumerate(masks):
            out[n, c] = counts_from_caps(caps[c], np.asarray(mask, bool))
    return out
