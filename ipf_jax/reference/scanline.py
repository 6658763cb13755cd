"""The scanline method in vectorised NumPy: the fair NumPy baseline for the JAX kernels.

Not an oracle (that is :mod:`ipf_jax.reference.raster`, exact integers on the whole image): this
is what a careful NumPy programmer would write for speed, with the same integers as
:mod:`ipf_jax.likelihood.raster` (its quantisation and exact row intervals are called with ``xp=numpy``), so
the counts are equal to the JAX kernels' and the reference's exactly. Work is vectorised over a
chunk of particles; each capsule is rasterised only on the rows and words it can touch in that
chunk (:func:`ipf_jax.likelihood.raster.segment_extent`), its row intervals become bit-packed uint32 words,
ORed into the model's union grid, ANDed with the mask and counted with ``np.bitwise_count``.

The geometry runs the JAX modules' FK and projection code on NumPy float64 arrays, vectorised over
particles (the per-particle reference geometry is a thousand times slower and would not be a fair
baseline). API mirrors :mod:`ipf_jax.likelihood.scorer` / :mod:`ipf_jax.reference.likelihood`.
"""
from __future__ import annotations

import numpy as np

from ..geometry.camera import Camera, CameraArrays, project_spheres, stack_cameras
from ..geometry.capsule2d import capsule_outline
from ..geometry.kinematics import forward_kinematics
from ..likelihood.raster import (
    WORD,
    QuantCaps,
    pack_rows,
    quant_scale,
    quantize,
    row_intervals,
    segment_extent,
)

__all__ = ["project_capsules", "counts_from_caps", "counts"]


def project_capsules(particles: np.ndarray, shape_values, up, cameras: list[Camera]) -> np.ndarray:
    """(N, D) particles -> (N, C, S, 15) float32 capsule records (float64 arithmetic)."""
    particles = np.asarray(particles, np.float64)
    pose = forward_kinematics(particles, np.asarray(shape_values, np.float64),
                              np.asarray(up, np.float64), xp=np)
    stacked = stack_cameras(cameras, np.float64)
    out = []
    for c in range(len(cameras)):
        cam = CameraArrays(*(field[c] for field in stacked))
        uv0, r0, in0 = project_spheres(cam, pose.seg_a, pose.seg_r[:, 0], xp=np)
        uv1, r1, in1 = project_spheres(cam, pose.seg_b, pose.seg_r[:, 1], xp=np)
        out.append(capsule_outline(np, uv0, r0, uv1, r1, in0 & in1))
    return np.stack(out, axis=1)


def _ones_below(n: np.ndarray) -> np.ndarray:
    """uint32 with the low ``n`` bits set, 0 <= n <= 32."""
    n = n.astype(np.uint32)
    low = np.left_shift(np.uint32(1), np.minimum(n, np.uint32(31))) - np.uint32(1)
    return np.where(n >= 32, np.uint32(0xFFFFFFFF), low)


def counts_from_caps(caps: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """(N, S, 15) float32 capsule records against one (H, W) boolean mask -> (N, 3) int64
    counts (Nc, Ns, Nm)."""
    caps = np.asarray(caps, np.float32)
    mask = np.asarray(mask, bool)
    h, w = mask.shape
    q, long_side = quant_scale(h, w), max(h, w)
    qc = quantize(np, caps, q, long_side)
    ext = segment_extent(np, caps, long_side)  # (N, S, 4)
    r_lo, r_hi = ext[..., 0].min(0), ext[..., 1].max(0)  # (S,): over the chunk's particles
    c_lo, c_hi = ext[..., 2].min(0), ext[..., 3].max(0)
    seen = np.nonzero((r_lo < h) & (r_hi >= 0) & (c_lo < w) & (c_hi >= 0))[0]
    n = len(caps)
    fg = int(np.count_nonzero(mask))
    if len(seen) == 0:
        return np.stack([np.zeros(n, np.int64), np.full(n, fg), np.zeros(n, np.int64)], -1)
    rows = [(int(max(r_lo[s], 0)), int(min(r_hi[s], h - 1))) for s in seen]
    words = [(int(max(c_lo[s], 0)) // WORD, int(min(c_hi[s], w - 1)) // WORD) for s in seen]
    g_row, g_word = min(r[0] for r in rows), min(k[0] for k in words)
    n_rows, n_words = max(r[1] for r in rows) - g_row + 1, max(k[1] for k in words) - g_word + 1
    grid = np.zeros((n, n_rows, n_words), np.uint32)  # the model's union, bit-packed
    for s, (r0, r1), (k0, k1) in zip(seen, rows, words):
        one = QuantCaps(*(field[:, s:s + 1] for field in qc))  # (N, 1, ...)
        lo, hi = row_intervals(one, np.arange(r0, r1 + 1, dtype=np.int32), q, w, xp=np)
        lo, hi = np.maximum(lo[:, 0], 0), np.minimum(hi[:, 0], w - 1)  # (N, R) inside the image
        base = np.arange(k0, k1 + 1, dtype=np.int32) * WORD  # (Wd,)
        a = np.clip(lo[..., None] - base, 0, WORD)
        b = np.clip(hi[..., None] + 1 - base, 0, WORD)
        grid[:, r0 - g_row:r1 - g_row + 1, k0 - g_word:k1 - g_word + 1] |= (
            _ones_below(np.maximum(a, b)) ^ _ones_below(a))
    sil = pack_rows(mask)[g_row:g_row + n_rows, g_word:g_word + n_words]
    nc = np.bitwise_count(grid & sil).sum(axis=(1, 2), dtype=np.int64)
    nm = np.bitwise_count(grid).sum(axis=(1, 2), dtype=np.int64)
    return np.stack([nc, fg - nc, nm - nc], -1)


def counts(particles, shape_values, up, cameras: list[Camera], masks: list[np.ndarray], *,
           chunk: int = 256) -> np.ndarray:
    """(N, D) particles -> (N, C, 3) int64 counts (Nc, Ns, Nm), ``chunk`` particles at a time."""
    particles = np.atleast_2d(np.asarray(particles, np.float64))
    out = np.zeros((len(particles), len(cameras), 3), np.int64)
    for start in range(0, len(particles), chunk):
        caps = project_capsules(particles[start:start + chunk], shape_values, up, cameras)
        for c, mask in enumerate(masks):
            out[start:start + chunk, c] = counts_from_caps(caps[:, c], mask)
    return out
