"""The model's silhouette as the likelihood counts it, drawn pixel by pixel in NumPy.

Every pixel of the image is tested against every part of every capsule (disc0 | disc1 | quad), on
the fixed-point grid of :func:`ipf_jax.likelihood.raster.quantize` (the raster's definition, shared
by every implementation), then filled row-convex as :func:`ipf_jax.likelihood.raster.row_intervals`
does. It is the textbook form: no region of interest, no clamping, no bit tricks. Overlays and
synthetic data draw the model with it, and it is the oracle of the JAX kernels' pixel counts
(:mod:`ipf_jax.reference.raster`).
"""
from __future__ import annotations

import numpy as np

from .raster import quant_scale, quantize


def model_mask(caps: np.ndarray, height: int, width: int) -> np.ndarray:
    """(S, 15) float32 capsule records -> (height, width) bool model silhouette."""
    q = quant_scale(height, width)
    qc = quantize(np, np.asarray(caps, np.float32), q, max(height, width))
    disc, quad = qc.disc.astype(np.int64), qc.quad.astype(np.int64)
    py, px = np.mgrid[0:height, 0:width].astype(np.int64) * q
    mask = np.zeros((height, width), bool)
    for s in range(len(disc)):
        if not qc.drawn[s]:
            continue
        parts = np.zeros((height, width), bool)
        for cx, cy, r in disc[s]:
            parts |= (px - cx) ** 2 + (py - cy) ** 2 <= r * r
        if qc.quad_on[s]:
            inside = np.ones((height, width), bool)
            for k in range(4):
                a, b = quad[s, k], quad[s, (k + 1) % 4]
                inside &= (b[0] - a[0]) * (py - a[1]) - (b[1] - a[1]) * (px - a[0]) >= 0
            parts |= inside
        # row-convex fill: leftmost to rightmost inside pixel of this capsule on each row
        for row in np.nonzero(parts.any(axis=1))[0]:
            cols = np.nonzero(parts[row])[0]
            mask[row, cols[0]:cols[-1] + 1] = True
    return mask
