"""Hard rasterisation of 2D capsules and silhouette counts, in exact integer arithmetic (JAX).

Why integers: XLA may fuse ``a * b + c`` into one FMA while NumPy rounds twice, so float predicates
cannot promise bit-identical pixel sets. The raster stage therefore starts by quantising every
capsule record (:mod:`ipf_jax.capsule2d`) to a fixed-point grid of ``1/Q`` pixel (``Q = 8`` up to
1024 px, else 4; images up to 2048 px), after clipping coordinates to a guard band of half the
image's long side around it and radii to the long side. From there on every test is an int32
expression whose magnitude is bounded below 2**30, so JAX, NumPy and any chunking agree exactly.

A pixel (row ``i``, column ``j``) has its centre at ``(Q j, Q i)`` on that grid. A capsule's parts
are disc0, disc1 and the tangent quad (closed sets); on each row the capsule covers the columns from
its leftmost to its rightmost inside pixel centre (row-convex: for the exact hull of two discs this
changes nothing; it keeps fixed-point slivers between parts from splitting a row). Three kernels compute
the counts of a model silhouette ``M`` against a mask ``S`` inside a region of interest (ROI):

* :func:`dense_counts` tests every ROI pixel against every part: O(pixels x segments);
* :func:`scanline_counts` solves each part's row interval exactly (integer square root and floor
  division done as a float estimate plus one exact integer check), turns the union of intervals into bit-packed uint32 row words and counts with
  ``population_count``: O(rows x segments + rows x words x segments);
* :mod:`ipf_jax.reference.raster` does the dense test on the whole image in NumPy.

Both JAX kernels are written for ONE capsule set (one particle, one camera); callers vmap.
The ROI must contain every model and silhouette pixel (then the counts do not depend on it).
"""
from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from .capsule2d import FLAG

WORD = 32
_BIG = 1 << 14  # clamp for coordinate differences in the disc test (|d| <= 2**14 -> d^2 <= 2**28)


def quant_scale(height: int, width: int) -> int:
    """Fixed-point sub-pixel factor Q for an image size."""
    long_side = max(height, width)
    if long_side > 2048:
        raise ValueError(f"scoring resolution {width}x{height} exceeds 2048 px; lower --resolution")
    return 8 if long_side <= 1024 else 4


class QuantCaps(NamedTuple):
    """Quantised capsules, int32, leading axis S.

    disc : (S, 2, 3) (cx, cy, r) per disc;  quad : (S, 4, 2) corners;
    drawn : (S,) bool;  quad_on : (S,) bool.
    """

    disc: jnp.ndarray
    quad: jnp.ndarray
    drawn: jnp.ndarray
    quad_on: jnp.ndarray


def quantize(xp, caps: jnp.ndarray, q: int, long_side: int):
    """(S, 15) float32 capsule records -> :class:`QuantCaps` (shared by JAX and NumPy).

    Only exact float32 operations (clip, multiply by a power of two, round-half-even) are used
    before the cast, so both array libraries produce identical integers.
    """
    caps = caps.astype(xp.float32)
    lo, hi = np.float32(-0.5 * long_side), np.float32(1.5 * long_side)

    def coord(a):
        return xp.round(xp.clip(a, lo, hi) * np.float32(q)).astype(xp.int32)

    def radius(a):
        return xp.round(xp.clip(a, np.float32(0), np.float32(long_side)) * np.float32(q)).astype(xp.int32)

    disc = xp.stack([
        xp.stack([coord(caps[..., 0]), coord(caps[..., 1]), radius(caps[..., 2])], axis=-1),
        xp.stack([coord(caps[..., 3]), coord(caps[..., 4]), radius(caps[..., 5])], axis=-1),
    ], axis=-2)
    quad = coord(caps[..., 6:14]).reshape(caps.shape[:-1] + (4, 2))
    flag = caps[..., FLAG]
    drawn = flag > 0.5
    quad_on = (flag > 1.5) & _proper_quad(xp, quad)
    return QuantCaps(disc, quad, drawn, quad_on)


def _cross(ax, ay, bx, by):
    return ax * by - ay * bx


def _proper_quad(xp, quad):
    """Convex, positively oriented, positive area: then its 4 half-planes bound exactly it."""
    e = xp.roll(quad, -1, axis=-2) - quad  # (..., 4, 2) edges
    turns = _cross(e[..., 0], e[..., 1], xp.roll(e, -1, axis=-2)[..., 0], xp.roll(e, -1, axis=-2)[..., 1])
    d1 = quad[..., 2, :] - quad[..., 0, :]
    d2 = quad[..., 3, :] - quad[..., 1, :]
    area2 = _cross(d1[..., 0], d1[..., 1], d2[..., 0], d2[..., 1])
    return (area2 > 0) & xp.all(turns >= 0, axis=-1)


def _isqrt(m):
    """floor(sqrt(m)) for int32 0 <= m < 2**30, exact: nearest integer of the float root, then one
    integer check (the float root is within 0.01 of the truth at these magnitudes)."""
    s = jnp.round(jnp.sqrt(m.astype(jnp.float32))).astype(jnp.int32)
    return jnp.where(s * s > m, s - 1, s)


def _bound(c, d, inv_d, t_lo, t_hi):
    """Extreme integer t with ``d * t <= c`` (the largest if d > 0, the smallest if d < 0).

    Exact whenever that t lies inside (t_lo, t_hi): the float quotient is then within 0.01 of c/d,
    its nearest integer n is the answer or off by one, and one integer product decides. Outside
    the window the clipped value keeps the right side, which is all the caller needs (the bound
    then falls outside the image). No integer division: it is not vectorised on CPUs.
    """
    n = jnp.round(c.astype(jnp.float32) * inv_d)
    n = jnp.clip(n, t_lo.astype(jnp.float32), t_hi.astype(jnp.float32)).astype(jnp.int32)
    ok = d * n <= c
    return jnp.where(ok, n, n - jnp.sign(d))


def row_intervals(qc: QuantCaps, rows: jnp.ndarray, q: int, width):
    """Exact column interval of every capsule on every row (row-convex fill of its parts).

    rows : (R,) int32 image rows.  Returns lo, hi : (S, R) int32, clipped to [-1, width] (empty
    when lo > hi). A capsule covers, on each row, the columns from the leftmost to the rightmost
    pixel centre inside any of its parts (disc0, disc1, quad); for the true hull of two discs this
    is the hull itself, and it keeps quantisation slivers from splitting a row.
    """
    shift = q.bit_length() - 1  # q is a power of two: x >> shift == floor(x / q)
    py = rows[None, :] * q  # (1, R)
    big = jnp.int32(1 << 20)
    lo = jnp.full((qc.disc.shape[0], rows.shape[0]), big, jnp.int32)  # (S, R)
    hi = -lo
    for k in range(2):
        cx, cy, r = (qc.disc[:, k, i][:, None] for i in range(3))  # (S, 1)
        dy = jnp.clip(py - cy, -_BIG, _BIG)
        m = r * r - dy * dy
        s = _isqrt(jnp.maximum(m, 0))
        d_lo, d_hi = -((s - cx) >> shift), (cx + s) >> shift  # ceil((cx - s) / q), floor(...)
        ok = (m >= 0) & (d_lo <= d_hi)  # a chord may hold no pixel centre
        lo = jnp.where(ok, jnp.minimum(lo, d_lo), lo)
        hi = jnp.where(ok, jnp.maximum(hi, d_hi), hi)
    # quad: intersection of 4 half-planes  ey * (Q j - ax) <= c = ex * (py - ay)
    q_lo = jnp.full_like(lo, -big)
    q_hi = jnp.full_like(hi, big)
    q_ok = jnp.broadcast_to(qc.quad_on[:, None], lo.shape)
    for k in range(4):
        a, b = qc.quad[:, k], qc.quad[:, (k + 1) % 4]
        ax, ay = a[:, 0:1], a[:, 1:2]
        ex, ey = b[:, 0:1] - ax, b[:, 1:2] - ay  # (S, 1)
        c = ex * (py - ay)  # (S, R)
        # window of t = Q j - ax that matters for columns -2 .. width + 2
        t_lo, t_hi = -2 * q - ax - 2, (width + 2) * q - ax + 2
        inv = 1.0 / jnp.where(ey == 0, 1, ey).astype(jnp.float32)
        t = _bound(c, ey, inv, t_lo, t_hi)
        q_hi = jnp.where(ey > 0, jnp.minimum(q_hi, (t + ax) >> shift), q_hi)
        q_lo = jnp.where(ey < 0, jnp.maximum(q_lo, -((-(t + ax)) >> shift)), q_lo)
        q_ok = q_ok & ((ey != 0) | (c >= 0))
    q_ok = q_ok & (q_lo <= q_hi)
    lo = jnp.where(q_ok, jnp.minimum(lo, q_lo), lo)
    hi = jnp.where(q_ok, jnp.maximum(hi, q_hi), hi)
    drawn = qc.drawn[:, None]
    lo = jnp.where(drawn, jnp.clip(lo, -1, width), width)
    hi = jnp.where(drawn, jnp.clip(hi, -1, width), -1)
    return lo, hi


def _ones_below(n):
    """uint32 with the low ``n`` bits set, 0 <= n <= 32."""
    n = n.astype(jnp.uint32)
    return jnp.where(n >= 32, jnp.uint32(0xFFFFFFFF),
                     (jnp.uint32(1) << jnp.minimum(n, 31)) - jnp.uint32(1))


class Roi(NamedTuple):
    """A window of ``rows`` x ``words`` (static sizes) starting at (row0, word0) (dynamic)."""

    row0: jnp.ndarray
    word0: jnp.ndarray


def pack_intervals(lo, hi):
    """Two int32 arrays of columns in [-1, 4094] -> one int32 array (a single output keeps XLA
    from fusing the interval stage into every consumer and recomputing it per word)."""
    return ((lo + 1) << 12) | (hi + 1)


def unpack_intervals(packed):
    return (packed >> 12) - 1, (packed & 4095) - 1


def interval_stage(caps: jnp.ndarray, rows: jnp.ndarray, q: int, long_side: int, width):
    """Stage 1 of the scanline kernel: (S, 15) records -> (S, R) packed row intervals."""
    qc = quantize(jnp, caps, q, long_side)
    return pack_intervals(*row_intervals(qc, rows, q, width))


def word_stage(packed: jnp.ndarray, sil_words: jnp.ndarray, roi: Roi, n_rows: int, n_words: int,
               height, width):
    """Stage 2: packed intervals (S, R) -> (Nc, Nm_total) against one bit-packed mask.

    The union of the capsules' intervals becomes bit-packed row words (rows minor, so the loops
    vectorise), ANDed with the mask's words and counted with ``population_count``.
    """
    lo, hi = unpack_intervals(packed)
    rows = roi.row0 + jnp.arange(n_rows, dtype=jnp.int32)
    lo = jnp.maximum(lo, 0)
    hi = jnp.where(rows[None, :] < height, jnp.minimum(hi, width - 1), -1)
    base = ((roi.word0 + jnp.arange(n_words, dtype=jnp.int32)) * WORD)[:, None]  # (Wd, 1)
    m = jnp.zeros((n_words, n_rows), jnp.uint32)
    for s in range(lo.shape[0]):  # unrolled: XLA fuses the whole OR chain into one loop
        a = jnp.clip(lo[s][None, :] - base, 0, WORD)
        b = jnp.clip(hi[s][None, :] + 1 - base, 0, WORD)
        m = m | (_ones_below(jnp.maximum(a, b)) ^ _ones_below(a))
    sil = _sil_window(sil_words, roi, n_rows, n_words)
    nc = jnp.sum(jax.lax.population_count(m & sil).astype(jnp.int32))
    nm = jnp.sum(jax.lax.population_count(m).astype(jnp.int32))
    return nc, nm


def _sil_window(sil_words, roi: Roi, n_rows: int, n_words: int):
    return jax.lax.dynamic_slice(sil_words, (roi.row0, roi.word0), (n_rows, n_words)).T


def scanline_counts(caps: jnp.ndarray, sil_words: jnp.ndarray, roi: Roi, n_rows: int,
                    n_words: int, q: int, long_side: int, height, width):
    """(Nc, Nm_total) for one capsule set against one bit-packed mask (both stages in one call).

    caps : (S, 15) float32 records.  sil_words : (H_pad, W_words) uint32 packed mask.
    Returns int32 scalars: pixels in model & mask, pixels in model. The scorer runs the two
    stages as separate compiled calls (see :mod:`ipf_jax.likelihood`); this is the same math.
    """
    rows = roi.row0 + jnp.arange(n_rows, dtype=jnp.int32)
    packed = interval_stage(caps, rows, q, long_side, width)
    return word_stage(packed, sil_words, roi, n_rows, n_words, height, width)


def segment_inside(qc: QuantCaps, s: int, px: jnp.ndarray, py: jnp.ndarray):
    """Per-pixel membership in the parts of capsule ``s`` (before the row fill).

    px, py : (...) int32 fixed-point pixel centres.  Returns (...) bool.
    """
    inside = jnp.zeros(px.shape, bool)
    for k in range(2):
        cx, cy, r = qc.disc[s, k, 0], qc.disc[s, k, 1], qc.disc[s, k, 2]
        dx = jnp.clip(px - cx, -_BIG, _BIG)
        dy = jnp.clip(py - cy, -_BIG, _BIG)
        inside = inside | (dx * dx + dy * dy <= r * r)
    quad_in = qc.quad_on[s]
    for k in range(4):
        a, b = qc.quad[s, k], qc.quad[s, (k + 1) % 4]
        quad_in = quad_in & (_cross(b[0] - a[0], b[1] - a[1], px - a[0], py - a[1]) >= 0)
    return (inside | quad_in) & qc.drawn[s]


def dense_counts(caps: jnp.ndarray, sil_words: jnp.ndarray, roi: Roi, n_rows: int,
                 n_words: int, q: int, long_side: int, height, width):
    """Same contract as :func:`scanline_counts`, by testing every ROI pixel against every part.

    Each capsule's pixels are then filled row by row between its leftmost and rightmost inside
    pixel (the row-convex rule of :func:`row_intervals`).
    """
    qc = quantize(jnp, caps, q, long_side)
    rows = roi.row0 + jnp.arange(n_rows, dtype=jnp.int32)
    cols = roi.word0 * WORD + jnp.arange(n_words * WORD, dtype=jnp.int32)
    px, py = cols[None, :] * q, rows[:, None] * q
    cols_b = jnp.broadcast_to(cols[None, :], (n_rows, cols.shape[0]))
    model = jnp.zeros((n_rows, cols.shape[0]), bool)
    big = jnp.int32(1 << 20)
    for s in range(qc.disc.shape[0]):
        inside = segment_inside(qc, s, px, py)
        first = jnp.min(jnp.where(inside, cols_b, big), axis=1, keepdims=True)
        last = jnp.max(jnp.where(inside, cols_b, -big), axis=1, keepdims=True)
        model = model | ((cols_b >= first) & (cols_b <= last))
    model = model & (rows[:, None] < height) & (cols[None, :] < width)
    s = _sil_window(sil_words, roi, n_rows, n_words)  # (Wd, R)
    bits = (s.T[:, :, None] >> jnp.arange(WORD, dtype=jnp.uint32)) & jnp.uint32(1)
    sil = bits.reshape(n_rows, n_words * WORD).astype(bool)
    nc = jnp.sum((model & sil).astype(jnp.int32))
    nm = jnp.sum(model.astype(jnp.int32))
    return nc, nm


def pack_rows(mask: np.ndarray, n_words: int | None = None) -> np.ndarray:
    """Bit-pack a (H, W) boolean mask into (H, W_words) uint32 (bit b of word k = column 32k+b)."""
    h, w = mask.shape
    n_words = n_words or -(-w // WORD)
    padded = np.zeros((h, n_words * WORD), bool)
    padded[:, :w] = mask
    return np.packbits(padded, axis=1, bitorder="little").view("<u4").astype(np.uint32)
