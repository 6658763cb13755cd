"""The silhouette likelihood w = Nc / (Ns + Nm), jit-compiled and vmapped over particles.

Pipeline per particle: FK (:mod:`.kinematics`) -> each capsule projected into each camera as the
hull of its two end discs (:mod:`.camera`, :mod:`.capsule2d`) -> hard raster counts inside a region
of interest (:mod:`.raster`) -> counts ``(Nc, Ns, Nm)`` per camera. Weights are formed on the host in
float64 (:func:`weights_from_counts`), so they are identical for any chunking and backend.

Definitions (also in docs/formats.md):

* ``Nc`` model pixels on the mask; ``Ns = |mask| - Nc``; ``Nm = |model| - Nc`` (pixels inside the image).
* ``w_c = Nc / max(Ns + Nm, 1)``: when model and mask coincide exactly ``w_c = Nc``, the largest value
  any model can reach on that mask.
* A camera whose mask is empty on a frame is skipped for that frame (recorded by the tracker); ``w``
  is the mean of ``w_c`` over the remaining cameras; with none left the frame is missing.

:class:`Scorer` owns the compiled functions. It chooses the ROI (bounding box of every mask and of
every particle's model, so counts are exact), rounds it up to a size bucket that only grows (one
compile per bucket, none per frame), and evaluates particles in fixed-size chunks so memory stays
bounded and no array of shape (particles, H, W, segments) is ever built.
"""
from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from .body.shape import BodyShape
from .camera import Camera, CameraArrays, project_spheres, stack_cameras
from .capsule2d import capsule_outline
from .errors import IPFError, require
from .kinematics import forward_kinematics
from .raster import WORD, Roi, dense_counts, interval_stage, pack_rows, quant_scale, word_stage

KERNELS = ("scanline", "dense")


class Observation(NamedTuple):
    """One frame's masks at scoring resolution, ready for the scorer.

    words : (C, H_pad, W_words) uint32 bit-packed masks.   fg : (C,) int64 foreground counts.
    bbox : (C, 4) int64 (row_min, row_max, col_min, col_max), -1 rows when empty.
    sizes : (C, 2) int64 (height, width).
    """

    words: np.ndarray
    fg: np.ndarray
    bbox: np.ndarray
    sizes: np.ndarray

    @property
    def active(self) -> np.ndarray:
        """(C,) bool: cameras whose mask is not empty on this frame."""
        return self.fg > 0


def make_observation(masks: list[np.ndarray]) -> Observation:
    """Pack per-camera boolean masks (H_c, W_c) (already at scoring resolution)."""
    require(len(masks) > 0, "no masks")
    h_pad = max(m.shape[0] for m in masks)
    n_words = max(-(-m.shape[1] // WORD) for m in masks)
    words = np.zeros((len(masks), h_pad, n_words), np.uint32)
    fg = np.zeros(len(masks), np.int64)
    bbox = np.full((len(masks), 4), -1, np.int64)
    for c, m in enumerate(masks):
        m = np.asarray(m).astype(bool)
        words[c, : m.shape[0]] = pack_rows(m, n_words)
        fg[c] = int(m.sum())
        if fg[c]:
            rows = np.nonzero(m.any(axis=1))[0]
            cols = np.nonzero(m.any(axis=0))[0]
            bbox[c] = rows[0], rows[-1], cols[0], cols[-1]
    sizes = np.array([m.shape for m in masks], np.int64)
    return Observation(words, fg, bbox, sizes)


def project_capsules(q: jnp.ndarray, shape_values: jnp.ndarray, up: jnp.ndarray,
                     cams: CameraArrays) -> jnp.ndarray:
    """One particle -> (C, S, 15) float32 capsule records in every camera."""
    pose = forward_kinematics(q, shape_values, up)

    def one_camera(cam):
        uv0, r0, in0 = project_spheres(cam, pose.seg_a, pose.seg_r[:, 0])
        uv1, r1, in1 = project_spheres(cam, pose.seg_b, pose.seg_r[:, 1])
        return capsule_outline(jnp, uv0, r0, uv1, r1, in0 & in1)

    return jax.vmap(one_camera)(cams)


def model_bbox(caps: jnp.ndarray) -> jnp.ndarray:
    """(..., S, 15) records -> (..., 4) int32 conservative (row_min, row_max, col_min, col_max)."""
    drawn = caps[..., 14] > 0.5
    big = 1e6
    x = jnp.stack([caps[..., 0], caps[..., 3]], -1)
    y = jnp.stack([caps[..., 1], caps[..., 4]], -1)
    r = jnp.stack([caps[..., 2], caps[..., 5]], -1)
    d = drawn[..., None]
    rmin = jnp.min(jnp.where(d, y - r, big), axis=(-2, -1))
    rmax = jnp.max(jnp.where(d, y + r, -big), axis=(-2, -1))
    cmin = jnp.min(jnp.where(d, x - r, big), axis=(-2, -1))
    cmax = jnp.max(jnp.where(d, x + r, -big), axis=(-2, -1))
    box = jnp.stack([jnp.floor(rmin) - 1, jnp.ceil(rmax) + 1, jnp.floor(cmin) - 1, jnp.ceil(cmax) + 1], -1)
    return jnp.clip(box, -1e6, 1e6).astype(jnp.int32)


def _geometry_impl(q, shape_values, up, cams):
    """Stage 0: (B, D) particles -> (B, C, S, 15) capsule records and the chunk's (C, 4) bbox."""
    caps = jax.vmap(project_capsules, in_axes=(0, None, None, None))(q, shape_values, up, cams)
    box = model_bbox(caps)  # (B, C, 4)
    union = jnp.stack([box[..., 0].min(0), box[..., 1].max(0), box[..., 2].min(0), box[..., 3].max(0)], -1)
    return caps, union


def _intervals_impl(caps, row0, widths, n_rows, qs, long_side):
    """Stage 1 (scanline): (B, C, S, 15) records -> (B, C, S, R) packed row intervals."""

    def one_camera(c, r0, wd):
        rows = r0 + jnp.arange(n_rows, dtype=jnp.int32)
        return interval_stage(c, rows, qs, long_side, wd)

    return jax.vmap(jax.vmap(one_camera), in_axes=(0, None, None))(caps, row0, widths)


def _words_impl(packed, words, row0, word0, heights, widths, n_rows, n_words):
    """Stage 2 (scanline): packed intervals -> (B, C, 2) int32 (Nc, Nm_total)."""

    def one_camera(p, w, r0, w0, h, wd):
        return jnp.stack(word_stage(p, w, Roi(r0, w0), n_rows, n_words, h, wd))

    per_particle = jax.vmap(one_camera, in_axes=(0, 0, 0, 0, 0, 0))
    return jax.vmap(per_particle, in_axes=(0, None, None, None, None, None))(
        packed, words, row0, word0, heights, widths)


def _dense_impl(caps, words, row0, word0, heights, widths, n_rows, n_words, qs, long_side):
    """The dense kernel: (B, C, S, 15) records -> (B, C, 2)."""

    def one_camera(c, w, r0, w0, h, wd):
        return jnp.stack(dense_counts(c, w, Roi(r0, w0), n_rows, n_words, qs, long_side, h, wd))

    per_particle = jax.vmap(one_camera, in_axes=(0, 0, 0, 0, 0, 0))
    return jax.vmap(per_particle, in_axes=(0, None, None, None, None, None))(
        caps, words, row0, word0, heights, widths)


_geometry_jit = jax.jit(_geometry_impl)
_intervals_jit = jax.jit(_intervals_impl, static_argnames=("n_rows", "qs", "long_side"))
_words_jit = jax.jit(_words_impl, static_argnames=("n_rows", "n_words"))
_dense_jit = jax.jit(_dense_impl, static_argnames=("n_rows", "n_words", "qs", "long_side"))


class Scorer:
    """Batched silhouette scoring for fixed cameras and body shape.

    cameras : cameras at scoring resolution (C of them).  shape : BodyShape.
    up : (3, 3) canonical-to-world rotation.  kernel : "scanline" or "dense".
    chunk : particles per compiled call (static).
    """

    def __init__(self, cameras: list[Camera], shape: BodyShape, up: np.ndarray, *,
                 kernel: str = "scanline", chunk: int = 512):
        require(kernel in KERNELS, f"unknown kernel {kernel!r} (choose {', '.join(KERNELS)})")
        require(chunk >= 1, "chunk must be >= 1")
        self.cameras = list(cameras)
        self.cams = stack_cameras(self.cameras)
        self.set_shape(shape)
        self.up = np.asarray(up, np.float32)
        self.kernel = kernel
        self.chunk = int(chunk)
        self.heights = np.array([c.height for c in self.cameras], np.int32)
        self.widths = np.array([c.width for c in self.cameras], np.int32)
        self.long_side = int(max(self.heights.max(), self.widths.max()))
        self.q = quant_scale(int(self.heights.max()), int(self.widths.max()))
        self.h_pad = int(self.heights.max())
        self.w_words = int(-(-self.widths.max() // WORD))
        self._bucket = (0, 0)
        self.evaluations = 0  # particles scored so far (likelihood evaluations)

    def set_shape(self, shape: BodyShape) -> None:
        self.shape = shape
        self.shape_values = np.asarray(shape.values, np.float32)

    # -- ROI ---------------------------------------------------------------------------------
    def _chunks(self, particles: np.ndarray):
        n = len(particles)
        b = self.chunk
        for start in range(0, n, b):
            block = particles[start:start + b]
            if len(block) < b:
                pad = np.repeat(block[:1], b - len(block), axis=0)
                block = np.concatenate([block, pad])
            yield start, block.astype(np.float32)

    def geometry(self, particles: np.ndarray):
        """Stage 0 for every chunk: capsule records (kept on device) and the model's (C, 4) bbox."""
        caps, boxes = [], []
        for _, block in self._chunks(particles):
            c, box = _geometry_jit(block, self.shape_values, self.up, self.cams)
            caps.append(c)
            boxes.append(box)
        boxes = np.stack([np.asarray(b) for b in boxes])
        union = np.stack([boxes[..., 0].min(0), boxes[..., 1].max(0),
                          boxes[..., 2].min(0), boxes[..., 3].max(0)], -1)
        return caps, union

    def roi(self, model_box: np.ndarray, full: bool = False):
        """Window offsets (row0, word0) per camera and the static bucket (n_rows, n_words).

        Only the model's pixels need to be inside the window: Nc counts model pixels on the mask
        and |mask| is known, so the (possibly cluttered) mask's extent does not matter. The bucket
        only grows, so a run compiles a handful of shapes, never one per frame.
        """
        n_cam = len(self.cameras)
        if full:
            self._bucket = (self.h_pad, self.w_words)
            return np.zeros(n_cam, np.int32), np.zeros(n_cam, np.int32)
        r_lo = np.clip(model_box[:, 0], 0, self.heights - 1)
        r_hi = np.clip(model_box[:, 1], 0, self.heights - 1)
        w_lo = np.clip(model_box[:, 2], 0, self.widths - 1) // WORD
        w_hi = np.clip(model_box[:, 3], 0, self.widths - 1) // WORD
        need_rows = int((r_hi - r_lo + 1).max())
        need_words = int((w_hi - w_lo + 1).max())
        rows_step = max(16, -(-self.h_pad // 16))
        n_rows = min(self.h_pad, -(-need_rows // rows_step) * rows_step)
        n_words = min(self.w_words, -(-need_words // 2) * 2)
        n_rows, n_words = max(n_rows, self._bucket[0]), max(n_words, self._bucket[1])
        self._bucket = (n_rows, n_words)
        row0 = np.minimum(r_lo, self.h_pad - n_rows).astype(np.int32)
        word0 = np.minimum(w_lo, self.w_words - n_words).astype(np.int32)
        return row0, word0

    # -- scoring -----------------------------------------------------------------------------
    def counts(self, particles: np.ndarray, obs: Observation, *, full_roi: bool = False) -> np.ndarray:
        """(N, C, 3) int64 counts (Nc, Ns, Nm) for (N, D) particles."""
        particles = np.asarray(particles)
        require(particles.ndim == 2 and particles.shape[0] > 0, "particles must be a non-empty (N, D) array")
        if not np.all(np.isfinite(particles)):
            raise IPFError("particles contain NaN or inf")
        require(obs.words.shape[0] == len(self.cameras), "observation and cameras differ in number")
        if obs.words.shape[1:] != (self.h_pad, self.w_words):
            raise IPFError(f"mask size {obs.words.shape[1:]} does not match the cameras' scoring size")
        caps, box = self.geometry(particles)
        row0, word0 = self.roi(box, full=full_roi)
        n_rows, n_words = self._bucket
        out = np.empty((len(particles), len(self.cameras), 2), np.int64)
        for (start, _), c in zip(self._chunks(particles), caps):
            if self.kernel == "scanline":
                # separate compiled stages: fused together, XLA recomputes the intervals per word
                packed = _intervals_jit(c, row0, self.widths, n_rows=n_rows, qs=self.q,
                                        long_side=self.long_side)
                res = _words_jit(packed, obs.words, row0, word0, self.heights, self.widths,
                                 n_rows=n_rows, n_words=n_words)
            else:
                res = _dense_jit(c, obs.words, row0, word0, self.heights, self.widths, n_rows=n_rows,
                                 n_words=n_words, qs=self.q, long_side=self.long_side)
            take = min(self.chunk, len(particles) - start)
            out[start:start + take] = np.asarray(res)[:take]
        self.evaluations += len(particles)
        nc, nm_total = out[..., 0], out[..., 1]
        return np.stack([nc, obs.fg[None, :] - nc, nm_total - nc], -1)


def weights_from_counts(counts: np.ndarray, active: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(N, C, 3) counts and (C,) active cameras -> (w (N,), w_cam (N, C)) float64.

    Inactive cameras have ``w_cam = nan`` and are left out of the mean.
    """
    counts = np.asarray(counts, np.float64)
    nc, ns, nm = counts[..., 0], counts[..., 1], counts[..., 2]
    w_cam = nc / np.maximum(ns + nm, 1.0)
    w_cam = np.where(active[None, :], w_cam, np.nan)
    if not np.any(active):
        return np.full(len(counts), np.nan), w_cam
    return np.nanmean(w_cam[:, active], axis=1), w_cam
