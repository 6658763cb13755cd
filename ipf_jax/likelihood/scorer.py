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

:class:`Scorer` owns the compiled functions and runs them in three stages, because fused into one
program XLA recomputes the row intervals once per word:

1. geometry (all cameras, one batched program with the particle axis last): FK of the distinct
   capsule ends, all of them projected into all cameras in one step, each capsule's quantised
   row coefficients in every camera (:class:`~ipf_jax.likelihood.raster.RowCoeffs`, batch
   (C, S, B), the cameras in one array per field; the dense kernel gets the records' 15 fields,
   (C, S, B) each), and each capsule's extent in each camera, reduced
   over the particles (:func:`ipf_jax.likelihood.raster.segment_extent`);
2. row intervals of the camera's row list, each capsule's own rows of its window ((T, B));
3. bit words, union, AND with the mask, popcount.

Particles go in chunks of B (memory and cache stay bounded) and a call's chunks in blocks of K
(:class:`Chunking`; :func:`pick_chunking` fits B and K to a filter's calls): stage 1 is one
compiled call per block, stages 2 and 3 one per block and camera, each running its K chunks one
after the other (``lax.map``), so a frame dispatches a few programs instead of three per chunk
and camera (1.2-1.3x less time on a frame's particles; each K is one more program to load:
docs/benchmarks.md). On the CPU a call's programs run from several host threads at once (one per
core; each block cut into a part per thread, :meth:`Scorer._spread`): JAX's CPU client runs the
programs one thread dispatches one after the other, each using the other cores only in its
parallel loops.

Between stages 1 and 2 the host plans the windows (:meth:`Scorer.plan`): one window per camera and
capsule, shared by every particle of the frame, holding that capsule's pixels in all of them, a
union grid per camera holding all windows, and the row list (:func:`row_list`). Their sizes are
static, from fixed ladders of buckets that grow within a frame, shrink after
:data:`SHRINK_FRAMES` frames of smaller needs (:meth:`Scorer.new_frame`) and are forgotten after a
wide search (:meth:`Scorer.reset_windows`), so a run compiles a handful of shapes; their offsets
are data. Only the
model's pixels need to be inside: Nc counts model pixels on the mask and ``|mask|`` is known, so the
(possibly cluttered) mask's extent does not matter. Windows cut the work by the ratio of a capsule's
extent to the model's (about 4x for a standing person). A call's last few particles go in a
smaller chunk when :data:`SMALL_CHUNKS` are on, and each chunk is sharded over all local devices.
"""
from __future__ import annotations

import bisect
import collections
import concurrent.futures
import functools
import os
import threading
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
from jax.sharding import Mesh, NamedSharding, PartitionSpec

from ..body.shape import BodyShape
from ..errors import IPFError, require
from ..geometry.camera import (
    Z_NEAR,
    Camera,
    CameraArrays,
    broadcast_cameras,
    project_xyz,
    stack_cameras,
)
from ..geometry.capsule2d import outline_fields
from ..geometry.kinematics import SEGMENT_ENDS, SEGMENT_RADII, capsule_ends
from ..lowered import Program, register_namedtuple
from .raster import (
    WORD,
    Roi,
    RowCoeffs,
    RowList,
    batch_words,
    dense_interval_stage,
    list_intervals,
    pack_rows,
    quant_scale,
    quantize_fields,
    row_coeffs,
    segment_extent_fields,
)

KERNELS = ("scanline", "dense")
#: Particles per compiled call unless told: bounds memory, never changes a count.
DEFAULT_CHUNK = 512
#: Host and dispatch cost of one compiled call, in particles' worth of scoring: IPF's 6561
#: particles in one call of 16 chunks instead of 16 calls of one took 0.35 ms less per call
#: avoided with one camera (27.9 against 33.1 ms), APF's 4000 in one call of 8 chunks 1.3 ms less
#: with four (51.2 against 60.2 ms): 80-100 particles' worth (docs/benchmarks.md).
CALL_OVERHEAD = 80
#: Smaller compiled calls for a call's last particles, for scorers whose window sizes are fixed
#: (the shape fit's, once its windows hold the largest body: :meth:`Scorer.set_small_chunks`).
#: Its compass steps score 4-127 particles at a time; padded to a 216- or 512-particle chunk, such
#: a call cost 6-14 ms with 4 cameras instead of 1.4. Counts never depend on the chunking, but
#: each size is one more program per window size, so a scorer whose sizes follow the frames (the
#: tracker's) does not use them (measured: docs/benchmarks.md).
SMALL_CHUNKS = (32, 128)
#: Chunks in one compiled call at most (:class:`Chunking`'s ``block``, a power of two).
MAX_CALL_CHUNKS = 16
#: One-off cost of each program size (a call of one chunk, a call of a block) a filter's frame
#: uses, in particles' worth per frame: every such size is one more program per window size,
#: traced and loaded when the sizes change, and the geometry's takes ~0.25 s to load, ~2.5 s to
#: compile (IPF, one camera, 40 frames: calls of 8, 4 and 1 chunks, 19 programs against 7, 0.9 s
#: more per run, about 2000 particles' worth a frame). Counted as half of that: longer runs pay
#: it less, padding is paid on every frame. (At 512 the factored filter got blocks of 2, and its
#: 20-frame runs on 4 cameras took 0.82x the time of one chunk per call: docs/benchmarks.md.)
PROGRAM_COST = 1024
#: Frames whose window needs must all fit a smaller bucket before :meth:`Scorer.new_frame` shrinks
#: it (every new size is a compile of ~0.1 s with one camera; a frame's scoring is 30-50 ms).
SHRINK_FRAMES = 8


def default_threads() -> int:
    """Host threads that run a call's compiled programs at once: the CPU cores this process may
    use on the CPU backend, 1 on others (there asynchronous dispatch already overlaps them).

    JAX's CPU client runs the programs dispatched from one thread one after the other, each using
    the cores only in its parallel loops; programs called from two threads run side by side (a
    call's four cameras' raster programs took 1.3x less time: docs/benchmarks.md)."""
    if jax.default_backend() != "cpu":
        return 1
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not on Linux
        return max(1, os.cpu_count() or 1)


@functools.lru_cache(maxsize=None)
def _pool(threads: int) -> concurrent.futures.ThreadPoolExecutor:
    """One pool per thread count, shared by every scorer of the process."""
    return concurrent.futures.ThreadPoolExecutor(threads, thread_name_prefix="ipf-jax-scorer")


def scoring_cameras(cameras: list[Camera], resolution: int) -> tuple[list[Camera], list[float]]:
    """The cameras scaled so their long side is at most ``resolution`` px, and each one's scale."""
    require(16 <= resolution <= 2048, f"scoring resolution must be 16..2048 px (got {resolution})")
    scales = [min(1.0, resolution / max(c.width, c.height)) for c in cameras]
    return [c if s == 1.0 else c.scaled(s) for c, s in zip(cameras, scales)], scales


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


def projected_ends(q_t, shape_values, up, cams) -> tuple:
    """Particles (D, *batch), particle axis last -> (u, v, z, mag) of every distinct capsule end
    (:func:`ipf_jax.geometry.kinematics.capsule_ends`) in every camera, each (*lead, C, E, B)
    for ``batch = (*lead, B)``. ``shape_values`` (P,) or (P, *batch).

    Each end is placed once and projected into all cameras in one step. (The barriers do not
    make XLA keep the results in memory: its CPU pipeline removes them before fusing. They keep
    the simplifier from rewriting across them, which the tracks depend on to the last bit:
    :mod:`ipf_jax.geometry.kinematics`.)"""
    ends = jax.lax.optimization_barrier(capsule_ends(q_t, shape_values, up))  # (3, *lead, E, B)
    cam = broadcast_cameras(cams, 2)  # broadcasts as (C, 1, 1): the camera axis before (E, B)
    x, y, z = (e[..., None, :, :] for e in ends)
    return jax.lax.optimization_barrier(project_xyz(cam, x, y, z))


def end_discs(proj: tuple, radii, cams) -> tuple:
    """:func:`projected_ends` ((*lead, C, E, B) each) and the (S, 2) or (S, 2, *lead, B) end radii
    of the segments -> each segment's two end discs in every camera, ``(x0, y0, r0, x1, y1, r1,
    drawn)``, (*lead, C, S, B) each (``drawn``: both ends in front of the camera)."""
    u, v, z, mag = proj
    cam = broadcast_cameras(cams, 2)
    f = 0.5 * (cam.K[0, 0] + cam.K[1, 1])  # (C, 1, 1)

    def disc(end):
        idx, r = SEGMENT_ENDS[:, end], radii[:, end]
        # (S, 1), or a body per particle: (S, *lead, B) -> (*lead, 1, S, B)
        r = r[:, None] if r.ndim == 1 else jnp.moveaxis(r, 0, -2)[..., None, :, :]
        depth = z[..., idx, :]
        return (u[..., idx, :], v[..., idx, :], f * r / jnp.maximum(depth, Z_NEAR) * mag[..., idx, :],
                depth > Z_NEAR)

    (x0, y0, r0, in0), (x1, y1, r1, in1) = disc(0), disc(1)
    return x0, y0, r0, x1, y1, r1, in0 & in1


def capsule_fields(q, shape_values, up, cams) -> jnp.ndarray:
    """(B, D) particles -> (C, 15, S, B) float32 capsule records in every camera, particle axis
    last (it is the one the loops vectorise over). ``shape_values`` (P,) or (B, P)."""
    sv = shape_values.T  # (P,) or (P, B)
    discs = end_discs(projected_ends(q.T, sv, up, cams), sv[SEGMENT_RADII], cams)
    return jnp.stack(outline_fields(jnp, *discs), 1)


def box_union(xp, ext, axis: int):
    """(..., 4) extents (row_min, row_max, col_min, col_max) -> the box holding all of them along
    ``axis`` (JAX in the compiled stages, NumPy on the host)."""
    return xp.stack([ext[..., 0].min(axis), ext[..., 1].max(axis), ext[..., 2].min(axis),
                     ext[..., 3].max(axis)], -1)


# -- the compiled stages (B particles; batched here, once) --------------------------------------
def _geometry_impl(q, shape_values, up, cams, long_side, scan_q):
    """Stage 1: (B, D) particles -> the records of the C cameras, and (C, S, 4) float32 extents
    of each capsule over the chunk (row_min, row_max, col_min, col_max).

    The records are the capsule records, a tuple of their 15 fields of (C, S, B) each, or with
    ``scan_q`` (the scanline kernel's fixed-point scale; 0: records) each capsule's
    :class:`~ipf_jax.likelihood.raster.RowCoeffs` (batch (C, S, B)); :func:`camera_records` takes
    one camera's. A program's outputs are
    materialised, so the rows of stage 2 read them instead of recomputing the quantisation per row
    (computed in stage 2, XLA fused it into the row loop: barriers do not keep values in memory
    on its CPU backend, a program's outputs do).

    ``shape_values`` is (P,) (one body for every particle: tracking) or (B, P) (a body per particle:
    shape candidates are data, so scoring another candidate never recompiles)."""
    sv = shape_values.T  # (P,) or (P, B)
    discs = end_discs(projected_ends(q.T, sv, up, cams), sv[SEGMENT_RADII], cams)
    return _records(jax.lax.optimization_barrier(discs), long_side, scan_q)


def _records(discs, long_side, scan_q):
    """:func:`_geometry_impl` from one chunk's :func:`end_discs` ((C, S, B) each)."""
    # field by field: stacked as one (C, 15, S, B) array, the records were written twice (each
    # field, then the stack) and a block's loop copied the stack once more into its output; a
    # block of records took 1.3-1.4x as long (docs/benchmarks.md)
    caps = jax.lax.optimization_barrier(tuple(outline_fields(jnp, *discs)))  # 15 x (C, S, B)
    ext = segment_extent_fields(jnp, lambda i: caps[i], long_side)  # (C, S, B, 4)
    union = box_union(jnp, ext, 2)
    if not scan_q:
        return caps, union
    # field by field, never stacked (QuantFields: 2.3x faster than through QuantCaps' stacks);
    # every camera in one array per field: split into per-camera outputs, XLA computed each
    # camera's copy of each coefficient in a loop of its own (a one-chunk call took 1.23x as long:
    # benchmarks/geometry_ab.py --variant per-camera)
    qf = quantize_fields(jnp, lambda i: caps[i], scan_q, long_side)  # batch (C, S, B)
    return row_coeffs(jnp, qf, scan_q), union


def camera_records(recs, cam):
    """One camera's records of one chunk's :func:`_geometry_impl` records (the camera axis first
    in every field). ``cam``: an int, or a traced int32 scalar (one program serves every camera)."""
    return jax.tree.map(lambda a: jax.lax.dynamic_index_in_dim(a, cam, 0, keepdims=False), recs)


def _intervals_impl(rc, rows, height, width, q):
    """Stage 2 (scanline), one camera: RowCoeffs of batch (S, B) -> (T, B) packed intervals of
    the :class:`~ipf_jax.likelihood.raster.RowList` ``rows``."""
    return list_intervals(rc, rows, q, height, width)


def _dense_impl(caps, rows, win_rows, win_words, height, width, n_win, n_win_words, q, long_side):
    """Stage 2 (dense), one camera: the same (T, B) packed intervals by per-pixel tests on each
    capsule's window, then picked in the list's order. ``caps``: the records' 15 fields, (S, B)
    each."""
    packed = jax.vmap(lambda c: dense_interval_stage(c.T, win_rows, win_words, n_win, n_win_words,
                                                     q, long_side, height, width),
                      in_axes=2, out_axes=2)(jnp.stack(caps))  # (S, R, B)
    return packed[rows.seg, rows.row - win_rows[rows.seg]]


def _words_impl(packed, rows, sil_words, row0, word0, win_rows, win_words, n_win, n_win_words,
                n_rows, n_words):
    """Stage 3, one camera: (T, B) packed intervals -> (B, 2) int32 (Nc, Nm_total)."""
    return jnp.stack(batch_words(packed, rows, sil_words, Roi(row0, word0), win_rows, win_words,
                                 n_win, n_win_words, n_rows, n_words), -1)


#: XLA options of the stages' programs. XLA's CPU backend prefers 256-bit vectors unless told;
#: the stages are loops over a whole particle axis, which 512-bit vectors run 1.15-1.4x faster
#: where the CPU has them (measured: docs/benchmarks.md). CPUs without them, and other backends,
#: ignore the option. The raster is exact integer arithmetic at any width; the capsule records
#: came out bit-identical on the bench scene.
COMPILER_OPTIONS = {"xla_cpu_prefer_vector_width": "512"}


def _compiled(fn, *static):
    """A stage's program; its lowering is kept on disk once the cache is on (:mod:`ipf_jax.lowered`)."""
    return Program(fn, static, COMPILER_OPTIONS)


for _t in (CameraArrays, RowCoeffs, RowList):  # the stages' named-tuple arguments and results
    register_namedtuple(_t)


#: Largest block of records (15 float32 fields per capsule, camera and particle) written block-wide
#: rather than chunk by chunk: 16.4 MB ran 1.09-1.2x faster so, 27 MB 0.94x (the Zen 4 EPYC,
#: twenty-ninth session; on the Xeon of the tenth, 27 MB of records and row coefficients block-wide
#: ran 0.64x)
BLOCK_WIDE_BYTES = 20 << 20


def _geometry_calls_impl(q, shape_values, up, cams, outs, long_side, scan_q):
    """Stage 1 for K chunks in one program: (K, B, D) particles -> the records of
    :func:`_geometry_impl` with a leading K axis, and the (C, S, 4) extents over all K chunks.
    ``shape_values`` (P,) or (K, B, P).

    The forward kinematics, the projection of the capsule ends and the segments' end discs run on
    all K x B particles at once (their arrays are small, and per chunk their many short loops cost
    more to start than to run; the discs block-wide: 1.07-1.09x, docs/benchmarks.md); the row
    coefficients (``scan_q``) chunk by chunk with their records and extents, each on a chunk's
    working set (over a whole block of 4 cameras they left the caches and ran 1.6x slower), the
    records alone block-wide up to :data:`BLOCK_WIDE_BYTES`. Every number is the one K calls of
    :func:`_geometry_impl` give (docs/benchmarks.md).

    ``outs``: buffers of the records to write the chunks into (:func:`record_buffers`; the
    program is called with them donated: a finished call's records, so XLA does not fill a new
    set with zeros for its loop first, a fifth of the stage's kernel time: docs/benchmarks.md),
    or None (new ones)."""
    q_t = jnp.moveaxis(q, -1, 0)  # (D, K, B)
    sv = shape_values if shape_values.ndim == 1 else jnp.moveaxis(shape_values, -1, 0)
    proj = projected_ends(q_t, sv, up, cams)  # (K, C, E, B) each
    discs = jax.lax.optimization_barrier(end_discs(proj, sv[SEGMENT_RADII], cams))  # (K, C, S, B)
    if not scan_q and 60 * discs[0].size <= BLOCK_WIDE_BYTES:
        # the records alone are elementwise: block-wide in one pass while they stay small (a
        # block of 4 cameras x 8 x 504 took 1.09-1.2x as long chunk by chunk into the buffers,
        # one of 16 x 416 0.94x: docs/benchmarks.md); the donated buffers are the outputs' shapes,
        # so XLA may write into them
        caps = jax.lax.optimization_barrier(tuple(outline_fields(jnp, *discs)))  # 15 x (K, C, S, B)
        ext = segment_extent_fields(jnp, lambda i: caps[i], long_side)  # (K, C, S, B, 4)
        return caps, box_union(jnp, box_union(jnp, ext, 3), 0)

    def chunk(k):
        return _records(jax.tree.map(lambda a: a[k], discs), long_side, scan_q)

    if outs is None:
        outs = _zero_records(q.shape[0], _record_layout(q.shape[1], cams.K.shape[0], scan_q))

    def step(k, carry):
        outs, union = carry
        rec, ext = chunk(k)
        outs = jax.tree.map(lambda o, x: jax.lax.dynamic_update_index_in_dim(o, x, k, 0), outs, rec)
        return outs, box_union(jnp, jnp.stack([union, ext]), 0)

    inf = np.float32(np.inf)
    empty = jnp.broadcast_to(jnp.array([inf, -inf, inf, -inf]), (len(cams.K), len(SEGMENT_ENDS), 4))
    return jax.lax.fori_loop(0, q.shape[0], step, (outs, empty))


@functools.lru_cache(maxsize=None)
def _record_layout(b: int, n_cams: int, scan_q: int):
    """Shapes and dtypes of one chunk's records, every camera (:func:`_records`)."""
    disc = jax.ShapeDtypeStruct((n_cams, len(SEGMENT_ENDS), b), np.float32)
    drawn = jax.ShapeDtypeStruct((n_cams, len(SEGMENT_ENDS), b), np.bool_)
    return jax.eval_shape(lambda d: _records(d, 1, scan_q)[0], (disc,) * 6 + (drawn,))


def _zero_records(k: int, layout):
    """Zeroed records of K chunks of ``layout`` (:func:`_record_layout`)."""
    return jax.tree.map(lambda a: jnp.zeros((k,) + a.shape, a.dtype), layout)


@functools.lru_cache(maxsize=None)
def _zeros_program(k: int, b: int, n_cams: int, scan_q: int):
    """One compiled call that makes a whole set of zeroed record buffers (one dispatch, not one
    per buffer)."""
    layout = _record_layout(b, n_cams, scan_q)
    return jax.jit(lambda: _zero_records(k, layout))


def record_buffers(k: int, b: int, n_cams: int, scan_q: int, device=None) -> tuple:
    """Zeroed buffers of the records of a block of K chunks of B particles (the layout
    :func:`_geometry_calls_impl` writes), for its first call; later calls reuse a finished call's.
    ``device``: placed there (committed, as a call's results are: the program is then not traced
    again for the buffers it gets back)."""
    zeros = _zeros_program(k, b, n_cams, scan_q)()
    return zeros if device is None else jax.device_put(zeros, device)


def _counts_impl(recs, cam, rows, sil_words, row0, word0, win_rows, win_words, height, width, q,
                 long_side, sizes, dense):
    """Stages 2 and 3 for K chunks in one program, one camera: the records of
    :func:`_geometry_calls_impl` (leading K axis, every camera) and the camera's index ``cam``
    (int32 scalar) -> (K, B, 2) int32 (Nc, Nm_total).

    ``sizes``: the camera's (R, Wd, grid rows, grid words), static. Chunk by chunk (``lax.map``),
    the row intervals then the words, as the separate programs :func:`_intervals_impl` (or
    :func:`_dense_impl`) and :func:`_words_impl` would: the word stage's capsule loop reads the
    intervals as a loop operand, so they are materialised once per chunk, not recomputed per
    word. One program instead of two per chunk (docs/benchmarks.md: with the geometry's one
    program, 1.1-1.3x less time on a frame's particles)."""
    n_win, n_win_words, n_rows, n_words = sizes

    def chunk(rec):
        rec = camera_records(rec, cam)
        if dense:
            packed = _dense_impl(rec, rows, win_rows, win_words, height, width, n_win, n_win_words,
                                 q, long_side)
        else:
            packed = _intervals_impl(rec, rows, height, width, q)
        return _words_impl(packed, rows, sil_words, row0, word0, win_rows, win_words, n_win,
                           n_win_words, n_rows, n_words)

    return jax.lax.map(chunk, recs)


#: The measure step's two programs (:meth:`Scorer.counts`).
_geometry_calls_jit = Program(_geometry_calls_impl, ("long_side", "scan_q"), COMPILER_OPTIONS,
                              donate_argnums=(4,))
_counts_jit = _compiled(_counts_impl, "q", "long_side", "sizes", "dense")
#: Each stage alone on one chunk (:meth:`Scorer.stages`: profiles and benchmarks).
_geometry_jit = _compiled(_geometry_impl, "long_side", "scan_q")
_intervals_jit = _compiled(_intervals_impl, "q")
_dense_jit = _compiled(_dense_impl, "n_win", "n_win_words", "q", "long_side")
_words_jit = _compiled(_words_impl, "n_win", "n_win_words", "n_rows", "n_words")


class Sizes(NamedTuple):
    """Static sizes (the compile keys): window rows R and words Wd, union grid rows and words,
    entries T of the row list."""

    win_rows: int
    win_words: int
    rows: int
    words: int
    list_rows: int


class Windows(NamedTuple):
    """Where the windows sit in one frame (host int32 arrays; data, not compile keys).

    row0, word0 : (C,) origin of each camera's union grid.
    win_rows, win_words : (C, S) origin of each capsule's window.
    rows : C :class:`~ipf_jax.likelihood.raster.RowList`, the rows stage 2 solves in each camera.
    """

    row0: np.ndarray
    word0: np.ndarray
    win_rows: np.ndarray
    win_words: np.ndarray
    rows: tuple


def _list_layout(skip: np.ndarray, count: np.ndarray, n_win: int) -> tuple[np.ndarray, int]:
    """Where each capsule's entries go in the row list: (``own`` (S,) the entry of each capsule's
    first row, entries needed). A window of R rows reads R entries from ``own - skip``, so it can
    run past the capsule's own entries by its rows below them (``R - skip - count``): the capsules
    go in decreasing order of that (the list then ends as early as it can: Jackson's rule), each
    one's rows after the last capsule's, or later when its window would start before the list (a
    gap of filler entries). A capsule seen nowhere (no rows) reads the list's first R entries, all
    masked."""
    own = skip.astype(np.int64).copy()  # unseen capsules: first = own - skip = 0
    cursor = 0
    for s in np.argsort(-(n_win - skip - count), kind="stable"):
        if count[s] > 0:
            own[s] = max(cursor, int(skip[s]))
            cursor = int(own[s] + count[s])
    return own, max(cursor, int(np.max(own - skip)) + n_win)


def row_list(win_rows: np.ndarray, skip: np.ndarray, count: np.ndarray, n_win: int,
             n_list: int, own: np.ndarray | None = None) -> RowList:
    """Host: the :class:`~ipf_jax.likelihood.raster.RowList` of each capsule's ``count[s]`` rows
    from row ``skip[s]`` of its window (S,), laid out by :func:`_list_layout` in ``n_list``
    entries, ``list_need(skip, count, n_win) <= n_list``; the entries no capsule owns are copies
    of a listed one (solved, never counted). ``own``: the layout's first entries when the caller
    has them already (:func:`_list_layout`)."""
    if own is None:
        own, _ = _list_layout(skip, count, n_win)
    step = np.arange(int(count.sum())) - np.repeat(np.cumsum(count) - count, count)  # 0.. per capsule
    at = np.repeat(own, count) + step
    seg_own = np.repeat(np.arange(len(count)), count)
    row_own = np.repeat(win_rows + skip, count) + step
    seg = np.full(n_list, seg_own[0] if len(at) else 0, np.int32)
    row = np.full(n_list, row_own[0] if len(at) else win_rows[0], np.int32)
    seg[at], row[at] = seg_own, row_own
    return RowList(seg, row, (own - skip).astype(np.int32), skip.astype(np.int32),
                   count.astype(np.int32))


def list_need(skip: np.ndarray, count: np.ndarray, n_win: int) -> int:
    """Entries :func:`row_list` needs for these capsules and windows of ``n_win`` rows."""
    return _list_layout(skip, count, n_win)[1]


def _round_up(n: int, step: int, cap: int) -> int:
    return min(cap, -(-max(n, 1) // step) * step)


class Chunking(NamedTuple):
    """How a scorer cuts a call: chunks of ``chunk`` particles, ``block`` chunks per compiled call
    (a power of two); a call's chunks beyond its whole blocks go one per call (or, asked, in one
    more block, padded: :meth:`Scorer.counts`)."""

    chunk: int
    block: int = 1


def call_blocks(n: int, chunking: Chunking, pad: bool = False) -> list[int]:
    """The chunks of each compiled call for a call of ``n`` particles: whole blocks, then one
    chunk per call (``pad``: one more block). The scorer cuts its calls by it
    (:meth:`Scorer._blocks`) and :func:`chunk_cost` models them by it."""
    chunks = -(-int(n) // chunking.chunk)
    whole, rest = divmod(chunks, chunking.block)
    return [chunking.block] * whole + ([chunking.block] if pad and rest else [1] * rest)


def chunk_cost(calls, chunking: Chunking) -> int:
    """Modelled cost of a frame's measure calls (particle counts), in particles' worth: every
    chunk is scored whole (a partial one is padded), each compiled call (:func:`call_blocks`) pays
    :data:`CALL_OVERHEAD` and each program size used :data:`PROGRAM_COST`."""
    blocks = [call_blocks(n, chunking) for n in calls]
    padded = sum(sum(b) for b in blocks) * chunking.chunk
    sizes = {k for b in blocks for k in b}
    return padded + CALL_OVERHEAD * sum(len(b) for b in blocks) + PROGRAM_COST * len(sizes)


def pick_chunking(calls, limit: int = DEFAULT_CHUNK, *, chunk: int | None = None, step: int = 8,
                  lowest: int = 64, gain: float = 0.1) -> Chunking:
    """The :class:`Chunking` for a filter whose frame makes measure calls of ``calls`` particles
    each: chunks of ``limit``, one per call, unless a chunk that is a multiple of ``step`` in
    ``lowest..limit`` and a block of 1..:data:`MAX_CALL_CHUNKS` chunks cut :func:`chunk_cost` by
    at least ``gain``. IPF's one call of 6561 gets 16 chunks of 416 in one compiled call (the
    6656 particles 13 chunks of 512 pad); the factored filter's 14 calls of 72-1017 particles
    chunks of 216. ``chunk`` given (``--chunk``): only the block is chosen. Counts never depend
    on it."""
    calls = [int(n) for n in calls if int(n) > 0]
    blocks = [1 << i for i in range(MAX_CALL_CHUNKS.bit_length())]
    if chunk is not None:
        chunks = [int(chunk)]
    elif not calls or limit <= lowest:
        return Chunking(int(limit))
    else:
        chunks = list(range(lowest, limit + 1, step))
    base = Chunking(chunks[0] if chunk is not None else int(limit))
    if not calls:
        return base
    best = min((Chunking(c, b) for c in chunks for b in blocks),
               key=lambda k: (chunk_cost(calls, k), -k.chunk, k.block))
    return best if chunk_cost(calls, best) <= (1.0 - gain) * chunk_cost(calls, base) else base


@functools.lru_cache(maxsize=None)
def _ladder(step: int, cap: int) -> tuple[int, ...]:
    """The bucket sizes one static size may take: multiples of ``step`` growing by >= 25 % a rung,
    ending at ``cap`` (a fixed set, so shrinking and growing again reuse compiled programs)."""
    rungs = [min(step, cap)]
    while rungs[-1] < cap:
        rungs.append(_round_up(max(rungs[-1] + step, rungs[-1] + rungs[-1] // 4), step, cap))
    return tuple(rungs)


def _bucket(old: int, need: int, step: int, cap: int, shrink: bool = False) -> int:
    """The bucket for ``need``: the smallest rung that holds it when that is larger than ``old``
    (a person walking towards a camera costs a few compiles, not one every few frames); with
    ``shrink`` (once per frame, on the frame's largest need), also when it is smaller. Else
    ``old``. The rungs are a fixed set, so a size met again reuses its compiled program."""
    rungs = _ladder(step, cap)
    new = rungs[bisect.bisect_left(rungs, min(max(need, 1), cap))]
    return new if new > old or shrink else old


class Scorer:
    """Batched silhouette scoring for fixed cameras and body shape.

    cameras : cameras at scoring resolution (C of them).  shape : BodyShape.
    up : (3, 3) canonical-to-world rotation.  kernel : "scanline" or "dense".
    chunk : particles per chunk (static; rounded up to a multiple of the device count).
    block : chunks per compiled call (a power of two; a call's chunks beyond its whole blocks go
        one per call). :func:`pick_chunking` chooses both from a filter's calls.
    devices : devices to shard each chunk's particle axis over (default: all local devices).
    threads : host threads that run a call's compiled programs at once (default
        :func:`default_threads`); counts never depend on it.
    """

    def __init__(self, cameras: list[Camera], shape: BodyShape, up: np.ndarray, *,
                 kernel: str = "scanline", chunk: int = DEFAULT_CHUNK, block: int = 1,
                 devices=None, threads: int | None = None):
        require(kernel in KERNELS, f"unknown kernel {kernel!r} (choose {', '.join(KERNELS)})")
        require(chunk >= 1, "chunk must be >= 1")
        self.threads = default_threads() if threads is None else int(threads)
        require(self.threads >= 1, f"threads must be >= 1 (got {threads})")
        require(1 <= block <= MAX_CALL_CHUNKS and block & (block - 1) == 0,
                f"block must be a power of two up to {MAX_CALL_CHUNKS} (got {block})")
        self.block = int(block)
        self.cameras = list(cameras)
        self.cams = stack_cameras(self.cameras)
        self.set_shape(shape)
        self.up = np.asarray(up, np.float32)
        self.kernel = kernel
        self.heights = np.array([c.height for c in self.cameras], np.int32)
        self.widths = np.array([c.width for c in self.cameras], np.int32)
        self.long_side = int(max(self.heights.max(), self.widths.max()))
        self.q = quant_scale(int(self.heights.max()), int(self.widths.max()))
        self.h_pad = int(self.heights.max())
        self.w_words = int(-(-self.widths.max() // WORD))
        self._list_cap = len(SEGMENT_ENDS) * self.h_pad  # row-list entries: every row of every capsule
        devices = list(jax.local_devices() if devices is None else devices)
        self.chunk = -(-int(chunk) // len(devices)) * len(devices)
        self._devices = len(devices)
        self._device = devices[0]
        self._small: list[int] = []  # :meth:`set_small_chunks`
        # one device: plain arrays; several: the particle axis is split across them (GSPMD)
        mesh = Mesh(np.array(devices), ("particles",)) if len(devices) > 1 else None
        # blocks are (K, B, ...): K chunks of B particles, B split
        self._split = None if mesh is None else NamedSharding(mesh, PartitionSpec(None, "particles"))
        self._whole = None if mesh is None else NamedSharding(mesh, PartitionSpec())
        self.sizes: list[Sizes] = []  # per camera, set by :meth:`plan`
        self._need: np.ndarray | None = None  # (C, 4) largest sizes asked since :meth:`new_frame`
        self._recent: collections.deque = collections.deque(maxlen=SHRINK_FRAMES)  # the last frames' needs
        self.evaluations = 0  # particles scored so far (likelihood evaluations)
        self._spare: dict = {}  # (K, B, scan_q) -> finished calls' record buffers (:meth:`_recycle`)
        self._spare_cap: dict = {}  # (K, B, scan_q) -> most sets a call has used

    def set_shape(self, shape: BodyShape) -> None:
        self.shape = shape
        self.shape_values = np.asarray(shape.values, np.float32)

    def _put(self, x, split: bool = False):
        if self._split is None:
            return x
        return jax.device_put(x, self._split if split else self._whole)

    def set_small_chunks(self, sizes: tuple[int, ...]) -> None:
        """Use smaller compiled calls for a call's last particles from now on (:data:`SMALL_CHUNKS`;
        ``()``: none). Worth it once the window sizes have stopped changing."""
        d = self._devices
        self._small = [b for b in sorted({-(-int(b) // d) * d for b in sizes} - {0}) if b < self.chunk]

    def block_size(self, left: int) -> int:
        """Particles in the compiled call for the next ``left`` particles of a call: the chunk,
        or for a call's last few the smallest of :data:`SMALL_CHUNKS` that holds them (a
        compass step's 4 poses are not scored as 512)."""
        return next((b for b in self._small if left <= b), self.chunk)

    def _blocks(self, n: int, pad: bool = False) -> list[tuple[int, int, int, int]]:
        """How a call of ``n`` particles is cut: (start, taken, K, B) per compiled call, K chunks
        of B particles each, as :func:`call_blocks` cuts it (the last chunk padded). With small
        chunks (:meth:`set_small_chunks`) the call's last particles get a call of their own instead
        (``pad`` is then not used)."""
        out, start = [], 0
        if not self._small:
            for k in call_blocks(n, Chunking(self.chunk, self.block), pad):
                out.append((start, min(n - start, k * self.chunk), k, self.chunk))
                start += k * self.chunk
            return out
        while start < n:  # whole chunks, then the last few in the smallest call that holds them
            left = n - start
            b = self.block_size(left)
            k = self.block if left // b >= self.block else 1
            take = min(left, k * b)
            out.append((start, take, k, b))
            start += take
        return out

    def _spread(self, cuts: list) -> list:
        """:meth:`_blocks`' cuts with each block of several chunks cut into :attr:`threads` parts
        (of ``ceil(K / threads)`` chunks, the last one padded when K is not a multiple), whose
        programs then run side by side (:meth:`_run`). Every block is cut as if full, whatever
        the call, so a padded block (``pad``: a start pose) runs on the programs the filter's calls
        use; a part holding none of the call's particles is dropped."""
        out = []
        for start, take, k, b in cuts:
            part = -(-k // min(self.threads, k))
            end = start + take
            out += [(s, min(part * b, end - s), part, b)
                    for s in range(start, start + k * b, part * b) if s < end]
        return out

    @staticmethod
    def _block(x: np.ndarray, start: int, take: int, k: int, b: int, dtype=np.float32) -> np.ndarray:
        """Rows ``start .. start + take`` of ``x`` as a (K, B, ...) block, padded with copies of
        its first row (a real particle: the extents stay the same)."""
        block = x[start:start + take]
        if take < k * b:
            block = np.concatenate([block, np.repeat(block[:1], k * b - take, axis=0)])
        return block.astype(dtype).reshape(k, b, *x.shape[1:])

    # -- stage 1 and the window plan -------------------------------------------------------------
    def geometry(self, particles: np.ndarray, shapes: np.ndarray | None = None,
                 kernel: str | None = None, cuts: list | None = None):
        """Stage 1 for every block of ``cuts`` (default :meth:`_blocks`): per block, the
        records of every camera for ``kernel``'s stage 2 (default the scorer's; leading axis K; kept
        on device), and the (C, S, 4) int64 extent of every capsule over all particles.
        ``shapes`` (N, P): a body per particle (default: :attr:`shape` for all)."""
        particles = np.asarray(particles)
        scan_q = self.q if (kernel or self.kernel) == "scanline" else 0

        cuts = cuts or self._blocks(len(particles))
        outs = [self._buffers(k, b, scan_q) for _, _, k, b in cuts]  # here: one thread takes them

        def call(item):
            (start, take, k, b), out = item
            block = self._put(self._block(particles, start, take, k, b), True)
            body = (self._put(self.shape_values) if shapes is None
                    else self._put(self._block(shapes, start, take, k, b), True))
            return _geometry_calls_jit(block, body, self.up, self.cams, out,
                                       long_side=self.long_side, scan_q=scan_q)

        done = self._run(call, lambda res: (res[0], np.asarray(res[1])), list(zip(cuts, outs)))
        recs = [rec for rec, _ in done]
        union = box_union(np, np.stack([ext for _, ext in done]).astype(np.int64), 0)
        return recs, union

    def _buffers(self, k: int, b: int, scan_q: int):
        """Buffers for a block's records: a finished call's (:meth:`_recycle`), else new ones;
        None for a call of one chunk, whose program makes its own (given buffers, the factored
        filter's calls of one chunk each ran 0.92-0.97x: docs/benchmarks.md)."""
        if k == 1:
            return None
        spare = self._spare.get((k, b, scan_q))
        if spare:
            return spare.pop()
        return record_buffers(k, b, len(self.cameras), scan_q, None if self._split else self._device)

    def _recycle(self, cuts: list, recs: list, scan_q: int) -> None:
        """Keep a finished call's record buffers (blocks of several chunks) for the next calls
        of the same blocks: every set it used, so a call like it takes them all again (making a
        set anew costs more than the zeros the donation saves), at most as many sets per block
        size as a call has used. With several devices none are kept: a buffer's sharding is the
        program's choice, and reusing it would trace the program again."""
        if self._split is not None:
            return
        kept = [((k, b, scan_q), rec) for (_, _, k, b), rec in zip(cuts, recs) if k > 1]
        for key, n in collections.Counter(key for key, _ in kept).items():
            self._spare_cap[key] = max(self._spare_cap.get(key, 0), n)
        for key, rec in kept:
            spare = self._spare.setdefault(key, [])
            if len(spare) < self._spare_cap[key]:
                spare.append(rec)

    def _run(self, call, read, items) -> list:
        """``[read(call(x)) for x in items]``: ``call`` dispatches a compiled program, ``read``
        waits for its result. On one thread every call is dispatched before the first read (the
        device works while the host dispatches). On :attr:`threads` threads each thread calls and
        reads its items, so the programs run side by side: JAX's CPU client runs the programs one
        thread dispatches one after the other. (A program that two threads meet first at once is
        traced and compiled once: ``jax.jit`` waits for the other thread's.)"""
        items = list(items)
        if self.threads == 1 or len(items) < 2:
            return [read(r) for r in [call(x) for x in items]]
        todo, out = iter(range(len(items))), [None] * len(items)
        lock = threading.Lock()

        def stream(_):  # take the next item, call it, then read the one called before
            held = None
            while True:
                with lock:
                    i = next(todo, None)
                res = None if i is None else (i, call(items[i]))
                if held is not None:
                    out[held[0]] = read(held[1])
                if res is None:
                    return
                held = res

        list(_pool(self.threads).map(stream, range(min(self.threads, len(items)))))
        return out

    def plan(self, ext: np.ndarray, full: bool = False) -> Windows:
        """Windows for capsule extents (C, S, 4); grows :attr:`sizes` (one per camera) when they
        do not fit. ``full``: every window is the whole image (the counts do not depend on it)."""
        n_cam, n_seg = ext.shape[:2]
        if full:
            n_list = n_seg * self.h_pad
            self.sizes = [Sizes(self.h_pad, self.w_words, self.h_pad, self.w_words, n_list)] * n_cam
            zero = np.zeros(n_cam, np.int32)
            zeros = np.zeros(n_seg, np.int64)
            whole = row_list(zeros, zeros, np.full(n_seg, self.h_pad), self.h_pad, n_list)
            return Windows(zero, zero, np.zeros((n_cam, n_seg), np.int32),
                           np.zeros((n_cam, n_seg), np.int32), (whole,) * n_cam)
        h, w = self.heights[:, None], self.widths[:, None]
        seen = (ext[..., 0] < h) & (ext[..., 1] >= 0) & (ext[..., 2] < w) & (ext[..., 3] >= 0)
        r_lo, r_hi = np.clip(ext[..., 0], 0, h - 1), np.clip(ext[..., 1], 0, h - 1)
        w_lo, w_hi = np.clip(ext[..., 2], 0, w - 1) // WORD, np.clip(ext[..., 3], 0, w - 1) // WORD

        def span(lo, hi):
            """Per camera: largest window, union of the visible capsules (first, size)."""
            win = np.max(np.where(seen, hi - lo + 1, 1), axis=1)
            g_lo = np.where(seen, lo, np.iinfo(np.int64).max).min(1)
            g_hi = np.where(seen, hi, -1).max(1)
            g_lo = np.where(g_hi >= 0, g_lo, 0)
            return win, np.maximum(g_hi - g_lo + 1, 1), g_lo

        win_r, grid_r, g_row = span(r_lo, r_hi)
        win_w, grid_w, g_word = span(w_lo, w_hi)
        # per camera (a camera nearer the person needs bigger windows); buckets from ladders
        # (_bucket) that only grow here and shrink in new_frame; the row list's after the windows
        need = np.stack([win_r, win_w, grid_r, grid_w, np.zeros_like(win_r)], 1).astype(np.int64)
        sizes = self._buckets(need, shrink=False)
        n_win, n_win_words, n_rows, n_words, _ = (np.array(v)[:, None] for v in zip(*sizes))
        row0 = np.minimum(g_row[:, None], self.h_pad - n_rows)
        word0 = np.minimum(g_word[:, None], self.w_words - n_words)
        # a window starts at its capsule, slid back inside the grid (it still holds the capsule)
        win_rows = np.clip(np.where(seen, r_lo, row0), row0, row0 + n_rows - n_win)
        win_words = np.clip(np.where(seen, w_lo, word0), word0, word0 + n_words - n_win_words)
        skip = np.where(seen, r_lo - win_rows, 0)  # window rows above the capsule (a slid window)
        count = np.where(seen, r_hi - r_lo + 1, 0)  # the capsule's own rows: the list holds these
        owns = []
        for c, sz in enumerate(sizes):
            own, need[c, 4] = _list_layout(skip[c], count[c], sz.win_rows)
            owns.append(own)
            sizes[c] = sz._replace(list_rows=_bucket(sz.list_rows, int(need[c, 4]), 8,
                                                     self._list_cap))
        self._need = need if self._need is None else np.maximum(self._need, need)
        self.sizes = sizes
        rows = tuple(row_list(win_rows[c], skip[c], count[c], sz.win_rows, sz.list_rows, owns[c])
                     for c, sz in enumerate(sizes))
        return Windows(row0[:, 0].astype(np.int32), word0[:, 0].astype(np.int32),
                       win_rows.astype(np.int32), win_words.astype(np.int32), rows)

    def _buckets(self, need: np.ndarray, shrink: bool) -> list[Sizes]:
        """Per camera, the static sizes holding ``need`` (C, 5): window rows and words, grid rows
        and words, row-list entries, from fixed ladders (:func:`_bucket`)."""
        sizes = []
        for c, (win_r, win_w, grid_r, grid_w, list_r) in enumerate(need.tolist()):
            old = self.sizes[c] if self.sizes else Sizes(0, 0, 0, 0, 0)
            n_win = _bucket(old.win_rows, win_r, 8, self.h_pad, shrink)
            n_win_words = _bucket(old.win_words, win_w, 1, self.w_words, shrink)
            n_rows = max(n_win, _bucket(old.rows, grid_r, 16, self.h_pad, shrink))
            n_words = max(n_win_words, _bucket(old.words, grid_w, 2, self.w_words, shrink))
            n_list = _bucket(old.list_rows, list_r, 8, self._list_cap, shrink)
            sizes.append(Sizes(n_win, n_win_words, n_rows, n_words, n_list))
        return sizes

    def reset_windows(self) -> None:
        """Forget the window sizes: the next :meth:`plan` sizes them to its own need (after a
        wide search, e.g. the initialisation, whose spread the tracked frames do not have)."""
        self.sizes, self._need = [], None
        self._recent.clear()

    def new_frame(self) -> None:
        """A new frame starts: the window buckets shrink to the largest need of the last
        :data:`SHRINK_FRAMES` frames when that is a smaller rung (the wide spread of an
        initialisation or a recovery search does not make every later frame pay its windows;
        within a frame they only grow, and waiting a few frames keeps a size that a frame in two
        needs, so it is not compiled again and again). Counts never depend on the windows."""
        if self._need is not None:
            self._recent.append(self._need)
        self._need = None
        if len(self._recent) == self._recent.maxlen:  # then plan has set the sizes
            self.sizes = self._buckets(np.max(np.stack(self._recent), axis=0), shrink=True)

    def stages(self, particles: np.ndarray, obs: Observation) -> dict:
        """Each compiled stage as ``(call, chunks)``, a zero-argument call on the first chunk of
        ``particles`` (``chunks`` 1) for profiling (:func:`ipf_jax.profiling.stage_timings`):
        ``geometry`` (all cameras; and, when ``particles`` fill a block of K chunks, the block's
        program as :meth:`counts` runs it, ``chunks`` K, and the same program with records only,
        without the row coefficients), then per camera ``intervals cam K``,
        ``words cam K`` and ``dense intervals cam K``. The windows are planned for ``particles``
        first, as :meth:`counts` does."""
        caps, ext = self.geometry(particles, kernel="scanline")
        dense_caps, _ = self.geometry(particles, kernel="dense")
        win = self.plan(ext)
        start, take, k, b = self._blocks(len(particles))[0]
        whole = self._put(self._block(np.asarray(particles), start, take, k, b), True)
        block = whole[0]
        out = {"geometry (all cameras)": lambda: _geometry_jit(
            block, self.shape_values, self.up, self.cams, long_side=self.long_side,
            scan_q=self.q)}
        chunks = {}  # calls of several chunks: the block's program, as the tracker runs it
        # and with records only: the capsule records and extents without the quantisation and
        # row coefficients, which the row stage did before they moved here (the stage's work of
        # older revisions, so the stage can be compared with theirs like for like)
        blocks = ((f"geometry, block of {k}", self.q), (f"geometry, block of {k}, records only", 0))
        for name, q in blocks if k > 1 else ():
            chunks[name] = k
            held = [record_buffers(k, b, len(self.cameras), q, self._device)]

            def block_call(held=held, q=q):  # into the last call's buffers, as counts runs it
                held[0], ext = _geometry_calls_jit(whole, self.shape_values, self.up, self.cams,
                                                   held[0], long_side=self.long_side, scan_q=q)
                return held[0], ext

            out[name] = block_call
        for c in range(len(self.cameras)):
            # the first chunk's records (the K axis of the first block dropped)
            rc, cap = camera_records(jax.tree.map(lambda a: a[0], (caps[0], dense_caps[0])), c)
            h, w, sz = self.heights[c], self.widths[c], self.sizes[c]

            def intervals(rc=rc, c=c, h=h, w=w):
                return _intervals_jit(rc, win.rows[c], h, w, q=self.q)

            packed = intervals()
            out[f"intervals cam {c + 1}"] = intervals
            out[f"words cam {c + 1}"] = lambda packed=packed, c=c, sz=sz: _words_jit(
                packed, win.rows[c], obs.words[c], win.row0[c], win.word0[c], win.win_rows[c],
                win.win_words[c], n_win=sz.win_rows, n_win_words=sz.win_words, n_rows=sz.rows,
                n_words=sz.words)
            out[f"dense intervals cam {c + 1}"] = lambda cap=cap, c=c, h=h, w=w, sz=sz: _dense_jit(
                cap, win.rows[c], win.win_rows[c], win.win_words[c], h, w, n_win=sz.win_rows,
                n_win_words=sz.win_words, q=self.q, long_side=self.long_side)
        return {name: (call, chunks.get(name, 1)) for name, call in out.items()}

    # -- scoring ---------------------------------------------------------------------------------
    def counts(self, particles: np.ndarray, obs: Observation, *, full_roi: bool = False,
               shapes: np.ndarray | None = None, pad: bool = False) -> np.ndarray:
        """(N, C, 3) int64 counts (Nc, Ns, Nm) for (N, D) particles.

        shapes : optional (N, P) shape values, one body per particle (the shape candidates of
        :mod:`ipf_jax.tracking.shape_fit`); default: every particle has :attr:`shape`.
        pad : the chunks left after the call's whole blocks run in one more block, padded, on
            the program of a block instead of one chunk per call: for a few particles scored
            once where the filter's calls use whole blocks (a run's start pose: IPF's one pose
            in 16 x 416 instead of a program of one chunk to load, 0.3-0.5 s, only for it;
            docs/benchmarks.md). Counts never depend on it.
        """
        particles = np.asarray(particles)
        require(particles.ndim == 2 and particles.shape[0] > 0, "particles must be a non-empty (N, D) array")
        if not np.all(np.isfinite(particles)):
            raise IPFError("particles contain NaN or inf")
        if shapes is not None:
            shapes = np.asarray(shapes, np.float32)
            require(shapes.shape == (len(particles), len(self.shape_values)),
                    f"shapes must be (N, {len(self.shape_values)}) like the particles")
            require(bool(np.all(np.isfinite(shapes))), "shape values contain NaN or inf")
        require(obs.words.shape[0] == len(self.cameras), "observation and cameras differ in number")
        if obs.words.shape[1:] != (self.h_pad, self.w_words):
            raise IPFError(f"mask size {obs.words.shape[1:]} does not match the cameras' scoring size")
        cuts = self._spread(self._blocks(len(particles), pad=pad))
        recs, ext = self.geometry(particles, shapes, cuts=cuts)
        win = self.plan(ext, full=full_roi)
        dense = self.kernel == "dense"
        per_cam = [(RowList(*(self._put(a) for a in win.rows[c])), self._put(obs.words[c]),
                    win.row0[c], win.word0[c], win.win_rows[c], win.win_words[c], self.heights[c],
                    self.widths[c], tuple(self.sizes[c][:4])) for c in range(len(self.cameras))]
        out = np.empty((len(particles), len(self.cameras), 2), np.int64)

        def call(task):  # one block in one camera
            i, c = task
            *args, sizes = per_cam[c]
            return task, _counts_jit(recs[i], np.int32(c), *args, q=self.q, long_side=self.long_side,
                                     sizes=sizes, dense=dense)

        def read(res):
            (i, c), counts = res
            start, take = cuts[i][:2]
            out[start:start + take, c] = np.asarray(counts).reshape(-1, 2)[:take]

        self._run(call, read, [(i, c) for i in range(len(cuts)) for c in range(len(self.cameras))])
        # the records' buffers are kept for the next call's geometry (donated to it); the other
        # device buffers are released here (dropped by the caller they cost it ~1 ms a frame, a
        # part of this step that looked like its own)
        self._recycle(cuts, recs, 0 if dense else self.q)
        recs = per_cam = None
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
