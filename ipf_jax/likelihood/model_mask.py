"""The model's silhouette as the likelihood counts it, drawn row by row in NumPy with exact
integers.

On the fixed-point grid of :func:`ipf_jax.likelihood.raster.quantize` (the raster's definition,
shared by every implementation), each row of a capsule is filled from its leftmost to its
rightmost candidate, as :func:`ipf_jax.likelihood.raster.solve_rows` defines them: for each disc
the row meets, the first pixel column at or right of its chord's left end and the last at or left
of its right end (in the image or not, holding a pixel centre or not), and where one of the quad's
two tangent sides crosses the row, the first column at or right of the crossing and the last at
or left of it. Here every root and quotient is exact integer arithmetic (int64 roots checked both
ways, floor division) where the JAX kernels use float estimates and one integer check: the
textbook form, the oracle of the JAX kernels' pixel counts (:mod:`ipf_jax.reference.raster`), and
what overlays and synthetic data draw.
"""
from __future__ import annotations

import numpy as np

from .raster import SIDES, quant_scale, quantize


def _chord(cx: int, cy: int, r: int, row_y: np.ndarray, q: int):
    """(first, last, meets) on fixed-point rows ``row_y``, exact: the first pixel column at or
    right of the disc's chord's left end, the last at or left of its right end (first > last where
    the chord holds no pixel centre), and whether the row meets the disc."""
    m = r * r - (row_y - cy) ** 2
    root = np.floor(np.sqrt(np.maximum(m, 0).astype(np.float64))).astype(np.int64)
    root = np.where(root * root > m, root - 1, root)  # float64's root of an integer < 2**52 is
    root = np.where((root + 1) ** 2 <= m, root + 1, root)  # within one of the integer root
    first, last = -((root - cx) // q), (cx + root) // q  # ceil((cx - root) / q), floor((cx + root) / q)
    return first, last, m >= 0


def capsule_rows(disc, quad, quad_on: bool, row_y: np.ndarray, q: int) -> tuple:
    """One drawn capsule's (first, last) pixel columns on fixed-point rows ``row_y`` (int64),
    exact and unclipped (first > last on a row it does not cover). ``disc``: its two quantised
    (cx, cy, r); ``quad``: its four quantised corners; ``quad_on``: whether its quad is drawn."""
    far = 1 << 40
    lo, hi = np.full(row_y.shape, far), np.full(row_y.shape, -far)
    for cx, cy, r in disc:
        first, last, meets = _chord(cx, cy, r, row_y, q)
        lo, hi = np.where(meets, np.minimum(lo, first), lo), np.where(meets, np.maximum(hi, last), hi)
    if quad_on:
        for k in SIDES:
            (ax, ay), (bx, by) = quad[k], quad[(k + 1) % 4]
            if ay == by:
                continue  # a flat side crosses no row (its ends are on the discs)
            rows = (row_y >= min(ay, by)) & (row_y <= max(ay, by))
            # where the side's line meets row y: x = ax + (bx - ax) (y - ay) / (by - ay)
            num, den = ax * (by - ay) + (bx - ax) * (row_y - ay), q * (by - ay)
            num, den = (-num, -den) if den < 0 else (num, den)
            lo = np.where(rows, np.minimum(lo, -(-num // den)), lo)  # first column at or right
            hi = np.where(rows, np.maximum(hi, num // den), hi)  # last column at or left
    return lo, hi


def model_mask(caps: np.ndarray, height: int, width: int) -> np.ndarray:
    """(S, 15) float32 capsule records -> (height, width) bool model silhouette."""
    q = quant_scale(height, width)
    qc = quantize(np, np.asarray(caps, np.float32), q, max(height, width))
    disc, quad = qc.disc.astype(np.int64).tolist(), qc.quad.astype(np.int64).tolist()
    row_y = np.arange(height, dtype=np.int64) * q
    mask = np.zeros((height, width), bool)
    for s in range(len(disc)):
        if not qc.drawn[s]:
            continue
        lo, hi = capsule_rows(disc[s], quad[s], bool(qc.quad_on[s]), row_y, q)
        lo, hi = np.clip(lo, 0, width), np.clip(hi, -1, width - 1)
        for row in np.nonzero(lo <= hi)[0]:
            mask[row, lo[row]:hi[row] + 1] = True
    return mask
