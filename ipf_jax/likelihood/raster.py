"""Hard rasterisation of 2D capsules and silhouette counts, in exact integer arithmetic (JAX).

Why integers: XLA may fuse ``a * b + c`` into one FMA while NumPy rounds twice, so float predicates
cannot promise bit-identical pixel sets. The raster stage therefore starts by quantising every
capsule record (:mod:`ipf_jax.geometry.capsule2d`) to a fixed-point grid of ``1/Q`` pixel (``Q = 8`` up to
1024 px, else 4; images up to 2048 px), after clipping coordinates to a guard band of half the
image's long side around it and radii to the long side. From there on every test is an int32
expression whose magnitude is bounded below 2**30, so JAX, NumPy and any chunking agree exactly.

A pixel (row ``i``, column ``j``) has its centre at ``(Q j, Q i)`` on that grid. On each row a
capsule covers the columns from its leftmost to its rightmost candidate (:func:`solve_rows`): the
ends of the row's chords of disc0 and disc1 (in the image or not, holding a pixel centre or not)
and the crossings of the tangent quad's two sides with the row, each rounded inwards to a pixel
centre. For the exact hull of two discs that is every pixel centre inside it (the hull's boundary
on a row lies on a circle or a side); on the fixed-point grid it keeps slivers between parts from
splitting a row. The quad's two chords across the discs are never tested (they lie inside the
discs): two sides a row instead of four edges (until 2026-12-07 the pixel centres inside disc0,
disc1 or the quad were filled the same way; counts moved by a few edge pixels:
docs/benchmarks.md).

Work is restricted to windows. Each capsule ``s`` is rasterised on a window of ``R`` rows starting
at ``win_rows[s]`` and ``Wd`` 32-bit words starting at ``win_words[s]``; the windows must hold every
in-image pixel of the capsule (:func:`segment_extent` bounds them) and then the counts do not depend
on where they are. Two kernels give the row intervals:

* :func:`list_intervals` (scanline) solves each row's candidates exactly (integer square root
  and division done as a float estimate plus one exact integer check) on the rows of a
  :class:`RowList`, each capsule's own rows of its window: O(rows x segments);
* :func:`dense_interval_stage` tests every window pixel against the discs, and adds the sides'
  crossings and the chords past the image's edges by exact integer division: O(pixels x segments).

:func:`batch_words` then turns the intervals into bit-packed uint32 row words, ORs the capsules'
windows into one grid (the union), ANDs it with the mask's words and counts with
``population_count``. :mod:`ipf_jax.reference.raster` counts on
:func:`~ipf_jax.likelihood.model_mask.model_mask`, the same rule row by row in NumPy with exact
integer roots and division (the oracle), and :mod:`ipf_jax.reference.scanline` runs the scanline
method, vectorised, in NumPy (it calls :func:`row_intervals` / :func:`solve_rows`, the same integer
code).

The scanline kernels take a batch of particles on the LAST axis (the row loops then vectorise over
whole particle vectors; with rows innermost they took 1.5-2x longer: docs/benchmarks.md);
:func:`interval_stage`, :func:`word_stage`, :func:`dense_interval_stage` and the ``*_counts`` are
their one-capsule-set forms (one particle, one camera), which callers vmap.
"""
from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from ..geometry.capsule2d import FLAG

WORD = 32
_BIG = 1 << 14  # clamp for coordinate differences in the disc test (|d| <= 2**14 -> d^2 <= 2**28)
_FAR = 1 << 20  # an interval bound beyond any image


def quant_scale(height: int, width: int) -> int:
    """Fixed-point sub-pixel factor Q for an image size."""
    long_side = max(height, width)
    if long_side > 2048:
        raise ValueError(f"scoring resolution {width}x{height} exceeds 2048 px; lower --resolution")
    return 8 if long_side <= 1024 else 4


def _guard(long_side: int):
    """Clip range of coordinates (the guard band) and of radii, float32."""
    return (np.float32(-0.5 * long_side), np.float32(1.5 * long_side), np.float32(long_side))


class QuantCaps(NamedTuple):
    """Quantised capsules, int32, leading axis S.

    disc : (S, 2, 3) (cx, cy, r) per disc;  quad : (S, 4, 2) corners;
    drawn : (S,) bool;  quad_on : (S,) bool.
    """

    disc: jnp.ndarray
    quad: jnp.ndarray
    drawn: jnp.ndarray
    quad_on: jnp.ndarray


class QuantFields(NamedTuple):
    """:class:`QuantCaps` field by field, each an array of the capsules' batch shape.

    disc : 2 x (cx, cy, r);  corners : 4 x (x, y);  drawn, quad_on : bool.

    The JAX stages use this form: XLA's CPU backend materialises stacks with small trailing axes
    (2, 3) and then runs every loop that reads them on strided elements; the geometry stage's row
    coefficients took 2.3x longer from the stacks (docs/benchmarks.md).
    """

    disc: tuple
    corners: tuple
    drawn: jnp.ndarray
    quad_on: jnp.ndarray


def quantize_fields(xp, field, q: int, long_side: int) -> QuantFields:
    """Capsule records -> :class:`QuantFields` (shared by JAX and NumPy); ``field(i)`` returns the
    records' field ``i`` (0 .. 14) as an array of the batch shape.

    Only exact float32 operations (clip, multiply by a power of two, round-half-even by
    :func:`_rint`) give the integers, so both array libraries produce identical ones. The records
    are finite (the scorer refuses non-finite particles and the projection bounds its divisions).
    """
    lo, hi, r_hi = _guard(long_side)

    def coord(i):  # |coordinate| <= 1.5 * 2048 * 4 on the grid: well inside _rint's range
        return _rint(xp, xp.clip(field(i).astype(xp.float32), lo, hi) * np.float32(q))

    def radius(i):
        return _rint(xp, xp.clip(field(i).astype(xp.float32), np.float32(0), r_hi) * np.float32(q))

    disc = ((coord(0), coord(1), radius(2)), (coord(3), coord(4), radius(5)))
    corners = tuple((coord(6 + 2 * k), coord(7 + 2 * k)) for k in range(4))
    flag = field(FLAG).astype(xp.float32)
    return QuantFields(disc, corners, flag > 0.5, (flag > 1.5) & _proper_quad(corners))


def quantize(xp, caps: jnp.ndarray, q: int, long_side: int) -> QuantCaps:
    """(S, 15) float32 capsule records -> :class:`QuantCaps` (:func:`quantize_fields`, stacked)."""
    qf = quantize_fields(xp, lambda i: caps[..., i], q, long_side)
    disc = xp.stack([xp.stack(d, axis=-1) for d in qf.disc], axis=-2)
    quad = xp.stack([xp.stack(c, axis=-1) for c in qf.corners], axis=-2)
    return QuantCaps(disc, quad, qf.drawn, qf.quad_on)


def as_fields(qc: QuantCaps) -> QuantFields:
    """:class:`QuantCaps` -> :class:`QuantFields` (views of its stacks)."""
    disc = tuple(tuple(qc.disc[..., k, i] for i in range(3)) for k in range(2))
    corners = tuple((qc.quad[..., k, 0], qc.quad[..., k, 1]) for k in range(4))
    return QuantFields(disc, corners, qc.drawn, qc.quad_on)


def segment_extent(xp, caps, long_side: int):
    """(..., S, 15) records -> (..., S, 4) float32 (row_min, row_max, col_min, col_max).

    A conservative bound of every pixel of each capsule *as quantised* (clipped to the guard band:
    a capsule far outside can reach into the image after clipping, so the raw record's box is not
    enough), one pixel of margin. Capsules that are not drawn get an empty box (min > max).

    The box is the two discs' boxes about their clipped centres, with radii clipped to twice the
    long side, not to the long side as the raster clips them: the quad's corners lie on the discs'
    circles (:mod:`ipf_jax.geometry.capsule2d`), and clipping is monotone and moves no two points
    further apart, so in each coordinate a clipped corner lies within the unclipped radius of its
    disc's clipped centre, and within the guard band's width (twice the long side) of it. The
    corners are not read. (Radii are taken by magnitude: a negative one, which no camera or body
    produces, still bounds its corners.)
    """
    return segment_extent_fields(xp, lambda i: caps[..., i], long_side)


def segment_extent_fields(xp, field, long_side: int):
    """:func:`segment_extent` of records given field by field: ``field(i)`` returns field ``i``
    (0 .. 14) as an array of the capsules' batch shape; -> (*batch, 4) float32."""
    lo, hi, r_hi = _guard(long_side)
    far = np.float32(1e9)

    def f32(i):
        return field(i).astype(xp.float32)

    # column by column (no small trailing axes): XLA's CPU loops are slow on those
    r0, r1 = (xp.minimum(xp.abs(f32(i)), np.float32(2) * r_hi) for i in (2, 5))
    drawn = f32(FLAG) > 0.5
    out = []
    for axis in (1, 0):  # rows come from y, columns from x
        c0, c1 = xp.clip(f32(axis), lo, hi), xp.clip(f32(3 + axis), lo, hi)
        low, high = xp.minimum(c0 - r0, c1 - r1), xp.maximum(c0 + r0, c1 + r1)
        out += [xp.where(drawn, xp.floor(low) - 1, far), xp.where(drawn, xp.ceil(high) + 1, -far)]
    return xp.stack(out, axis=-1)


def _cross(ax, ay, bx, by):
    return ax * by - ay * bx


def _proper_quad(corners):
    """Convex, positively oriented, positive area: then its 4 half-planes bound exactly it.

    corners : 4 (x, y) pairs of int32 arrays.
    """
    edges = [(corners[(k + 1) % 4][0] - corners[k][0], corners[(k + 1) % 4][1] - corners[k][1])
             for k in range(4)]
    convex = None
    for k in range(4):
        turn = _cross(*edges[k], *edges[(k + 1) % 4]) >= 0
        convex = turn if convex is None else convex & turn
    d1 = (corners[2][0] - corners[0][0], corners[2][1] - corners[0][1])
    d2 = (corners[3][0] - corners[1][0], corners[3][1] - corners[1][1])
    return (_cross(*d1, *d2) > 0) & convex


_ROUNDER = np.float32(3 << 22)  # 1.5 * 2**23: float32 sums in [2**23, 2**24) are whole numbers


def _rint(xp, x):
    """round-half-even(x) as int32 for float32 ``|x| < 2**22``: the bits of ``x + 1.5 * 2**23``,
    whose exponent is then fixed, less those of ``1.5 * 2**23``. Equal to ``round(x).astype(int32)``
    (one IEEE addition rounds to nearest even) without the saturating conversion XLA emits for a
    float-to-int cast (a NaN test, a range test and two selects a vector; measured:
    docs/benchmarks.md)."""
    y = (x + _ROUNDER).astype(xp.float32)
    bits = jax.lax.bitcast_convert_type(y, jnp.int32) if xp is jnp else np.asarray(y).view(np.int32)
    return bits - np.int32(0x4B400000)


def _isqrt(xp, m):
    """floor(sqrt(m)) for int32 0 <= m < 2**30, exact, and -1 for m < 0: nearest integer of the
    float root, then one integer check (the float root is within 0.01 of the truth at these
    magnitudes, below 2**15)."""
    s = _rint(xp, xp.sqrt(xp.maximum(m, 0).astype(xp.float32)))
    return xp.where(s * s > m, s - 1, s)


_INT_MAX = np.int32((1 << 31) - 1)


class RowCoeffs(NamedTuple):
    """What the row-interval solve needs of each capsule (:func:`row_coeffs`), arrays of the
    capsules' batch shape (a pytree: JAX maps over its leaves), int32 unless said.

    disc : 2 x (cx, cy, r^2) of disc0 and disc1 on the fixed-point grid; r^2 is -1 for a capsule
        not drawn (no row then meets its discs);
    side : 2 x (ex, n0, ad, y_lo, y_hi) of the quad's two tangent sides (T0- -> T1- and T1+ ->
        T0+). On a fixed-point row ``y`` with ``y_lo <= y <= y_hi`` the side crosses the row at
        column ``n / ad``, ``n = ex y + n0`` (the sign of the side's rise folded into ``ex`` and
        ``n0``, so ``ad`` > 0); a side that is flat, or of a capsule without a quad, has
        ``y_lo`` = int32 max and ``y_hi`` = 0 (no row);
    inv_d : 2 x 1/ad, float32.

    Computed once per capsule, not once per row: XLA fuses such per-capsule work into the row loop
    and, when the particle axis is the loop's innermost one, recomputes it for every row; and each
    select folded into a coefficient here is an operation fewer on every row (the row loop is
    arithmetic-bound; measured: docs/benchmarks.md). Tuples, not stacked arrays: the NumPy
    baseline calls this per capsule, and stacks would cost it time.
    """

    disc: tuple
    side: tuple
    inv_d: tuple


#: The quad's corners are T0+ T0- T1- T1+ (:mod:`ipf_jax.geometry.capsule2d`): its edges 1 and 3
#: are the tangent sides, edges 0 and 2 chords of disc0 and disc1.
SIDES = (1, 3)


def row_coeffs(xp, qf: QuantFields, q: int) -> RowCoeffs:
    """:class:`QuantFields` (batch ``qf.drawn.shape``) -> :class:`RowCoeffs`, exact int32
    (:func:`as_fields` gives them of stacked :class:`QuantCaps`)."""
    disc = tuple((cx, cy, xp.where(qf.drawn, r * r, -1).astype(xp.int32)) for cx, cy, r in qf.disc)
    sides = []
    for k in SIDES:
        (ax, ay), (bx, by) = qf.corners[k], qf.corners[(k + 1) % 4]
        ex, ey = bx - ax, by - ay
        # the crossing of row y: q ey j = ex y + (ey ax - ex ay); the sign of ey folded in
        sign = xp.where(ey < 0, -1, 1).astype(xp.int32)
        on = qf.quad_on & (ey != 0)
        sides.append((xp.where(on, sign * ex, 0).astype(xp.int32),
                      xp.where(on, sign * (ey * ax - ex * ay), 0).astype(xp.int32),
                      xp.where(on, xp.abs(ey) * q, 1).astype(xp.int32),
                      xp.where(on, xp.minimum(ay, by), _INT_MAX).astype(xp.int32),
                      xp.where(on, xp.maximum(ay, by), 0).astype(xp.int32)))
    inv_d = tuple(np.float32(1.0) / s[2].astype(xp.float32) for s in sides)
    return RowCoeffs(disc, tuple(sides), inv_d)


def solve_rows(rc: RowCoeffs, py, q: int, width, at, xp=jnp):
    """Exact column interval of every capsule on fixed-point rows ``py`` (row-convex fill).

    ``at`` maps a per-capsule array (the batch shape of ``rc``) to one that broadcasts against
    ``py`` (e.g. ``a[..., None]`` with rows last, ``a[:, None, :]`` with particles last). Returns
    lo, hi of the broadcast shape, int32, clipped to [-1, width] (empty when lo > hi).

    On each row a capsule covers the columns from the smallest leftmost candidate to the largest
    rightmost one: for each disc the row meets, the first pixel centre at or right of its chord's
    left end and the last at or left of its right end (a chord may hold none: it still bounds the
    row), and for each tangent side crossing the row, the first pixel centre at or right of the
    crossing and the last at or left of it. For the exact hull of two discs that is every pixel
    centre inside it: the hull's boundary on a row is on one of the two circles or one of the two
    sides, and ``ceil`` of the smallest end is the smallest ``ceil``. The quad's chords across
    the discs need no test (they lie inside the discs).
    """
    shift = q.bit_length() - 1  # q is a power of two: x >> shift == floor(x / q)
    lo = hi = None
    for k in range(2):
        cx, cy, rr = (at(a) for a in rc.disc[k])
        dy = xp.clip(py - cy, -_BIG, _BIG)
        m = rr - dy * dy
        s = _isqrt(xp, m)
        d_lo, d_hi = -((s - cx) >> shift), (cx + s) >> shift  # ceil((cx - s) / q), floor(...)
        ok = m >= 0  # the row meets the disc (a chord holding no pixel centre still bounds the row)
        if lo is None:
            lo, hi = xp.where(ok, d_lo, np.int32(_FAR)), xp.where(ok, d_hi, np.int32(-_FAR))
        else:
            lo = xp.where(ok, xp.minimum(lo, d_lo), lo)
            hi = xp.where(ok, xp.maximum(hi, d_hi), hi)
    # the sides' crossings n / ad (|n| < 2**30 for coordinates in the guard band): the float
    # quotient's nearest integer f is its floor or its ceiling whenever the quotient lies inside
    # (-width - 2, width + 2) (within 0.01 of it there), and one integer product tells which; a
    # crossing beyond that keeps its side of the image after the clip
    f_max = xp.asarray(width + 2).astype(xp.float32)
    for k in range(2):
        ex, n0, ad, y_lo, y_hi = (at(a) for a in rc.side[k])
        n = ex * py + n0
        f = _rint(xp, xp.clip(n.astype(xp.float32) * at(rc.inv_d[k]), -f_max, f_max))  # f_max whole
        p = ad * f
        crosses = (py >= y_lo) & (py <= y_hi)
        lo = xp.where(crosses, xp.minimum(lo, xp.where(p < n, f + 1, f)), lo)  # ceil(n / ad)
        hi = xp.where(crosses, xp.maximum(hi, xp.where(p > n, f - 1, f)), hi)  # floor(n / ad)
    return xp.clip(lo, -1, width), xp.clip(hi, -1, width)


def row_intervals(qc: QuantCaps, rows, q: int, width, xp=jnp):
    """Exact column interval of every capsule on every row (row-convex fill of its parts).

    rows : (R,) image rows shared by all capsules, or (S, R) rows per capsule (int32).
    Returns lo, hi : (S, R) int32, clipped to [-1, width] (empty when lo > hi). A capsule covers,
    on each row, the columns from the leftmost to the rightmost pixel centre inside any of its
    parts (disc0, disc1, quad); for the true hull of two discs this is the hull itself, and it
    keeps quantisation slivers from splitting a row. ``xp`` is the array namespace (NumPy for the
    vectorised NumPy baseline, which adds leading particle axes).
    """
    py = (rows if rows.ndim == qc.drawn.ndim + 1 else rows[..., None, :]) * q  # (..., S or 1, R)
    return solve_rows(row_coeffs(xp, as_fields(qc), q), py, q, width, lambda a: a[..., None], xp)


def pack_intervals(lo, hi, rows, height, width, xp=jnp):
    """Row intervals clipped to the image -> one int32 per row: ``(lo + 1) << 12 | (hi + 1)``.

    A single output keeps XLA from fusing the interval stage into every consumer (it would
    recompute the intervals once per word). Rows at or below ``height`` become empty.
    """
    lo = xp.maximum(lo, 0)
    hi = xp.where(rows < height, xp.minimum(hi, width - 1), -1)
    return ((lo + 1) << 12) | (hi + 1)


def unpack_intervals(packed):
    return (packed >> 12) - 1, (packed & 4095) - 1


def _window_rows(win_rows, n_win: int, xp=jnp):
    """(..., S) first rows -> (..., S, R) rows of each capsule's window."""
    return win_rows[..., None] + xp.arange(n_win, dtype=xp.int32)


class RowList(NamedTuple):
    """The rows stage 1 solves, as one list shared by the B particles (host or device int32).

    seg, row : (T,) the capsule and the image row of each entry. Capsule ``s``'s window of R rows
    starts at entry ``first[s]``; its own entries are the window's rows ``skip[s] .. skip[s] +
    count[s] - 1`` (entries ``first[s] + skip[s] ..``, the capsule's rows in order; ``count[s]``
    0 for a capsule seen nowhere), the window's other rows read entries of other capsules and are
    masked. ``first[s] >= 0``, ``first[s] + R <= T`` and ``skip[s] + count[s] <= R``. Unlike
    windows of R rows for every capsule, the list holds each capsule's own rows only: 1.5-1.8x
    fewer on the bench scene, where the capsule seen over the tallest spread sets R, and no rows
    above a capsule whose window was slid up to stay inside the union grid.
    """

    seg: jnp.ndarray
    row: jnp.ndarray
    first: jnp.ndarray
    skip: jnp.ndarray
    count: jnp.ndarray


def window_list(win_rows, n_win: int, xp=jnp) -> RowList:
    """The list of whole windows: R rows for each of the S capsules (T = S R)."""
    n_seg = win_rows.shape[0]
    seg = xp.repeat(xp.arange(n_seg, dtype=xp.int32), n_win)
    first = xp.arange(n_seg, dtype=xp.int32) * n_win
    return RowList(seg, _window_rows(win_rows, n_win, xp).reshape(-1), first,
                   xp.zeros((n_seg,), xp.int32), xp.full((n_seg,), n_win, xp.int32))


def list_intervals(rc: RowCoeffs, rows: RowList, q: int, height, width):
    """Scanline kernel, stage 1, particle axis last: :class:`RowCoeffs` of batch (S, B) -> (T, B)
    packed intervals of the list's rows.

    Particles last, the row loop vectorises over particles without a tail, and each entry's
    coefficients are one contiguous row of each (S, B) field (the gather fuses into the loop);
    they are read, not recomputed (measured: docs/benchmarks.md). The list's capsules are in
    range, so the gather clamps (``mode="clip"``, XLA's own rule: one scalar clamp a row) rather
    than fills: a filling gather guarded each of the 18 loads of every row with a branch and spilled
    the loop's registers (1.1x the frame's count time with APF and four cameras).
    """
    entry = jax.tree.map(lambda a: jnp.take(a, rows.seg, axis=-2, mode="clip"), rc)  # batch (T, B)
    lo, hi = solve_rows(entry, (rows.row * q)[:, None], q, width, lambda a: a)
    return pack_intervals(lo, hi, rows.row[:, None], height, width)


def interval_stage(caps, win_rows, n_win: int, q: int, long_side: int, height, width):
    """Scanline kernel, stage 1, one capsule set: (S, 15) records -> (S, R) packed intervals on
    each capsule's window (:func:`list_intervals` with one particle)."""
    rc = row_coeffs(jnp, quantize_fields(jnp, lambda i: caps[..., i], q, long_side), q)
    one = jax.tree.map(lambda a: a[..., None], rc)
    return list_intervals(one, window_list(win_rows, n_win), q, height, width).reshape(-1, n_win)


def discs_inside(qc: QuantCaps, px, py, xp=jnp):
    """Per-pixel membership in each capsule's discs (before the row fill).

    px, py : int32 fixed-point pixel centres broadcasting against (S, 1, 1) (e.g. (S, 1, X) and
    (S, R, 1)).  Returns (S, R, X) bool.
    """
    def per_seg(a):
        return a[:, None, None]

    inside = xp.zeros(xp.broadcast_shapes(px.shape, py.shape), bool)
    for k in range(2):
        cx, cy, r = (per_seg(qc.disc[:, k, i]) for i in range(3))
        dx = xp.clip(px - cx, -_BIG, _BIG)
        dy = xp.clip(py - cy, -_BIG, _BIG)
        inside = inside | (dx * dx + dy * dy <= r * r)
    return inside & per_seg(qc.drawn)


def side_crossings(qc: QuantCaps, py, q: int, xp=jnp):
    """Each capsule's tangent sides on fixed-point rows ``py`` (S, R), by exact integer division:
    (first, last) (S, R) int32, the first pixel column at or right of a side's crossing and the
    last at or left of one, over the sides that cross the row (``_FAR`` / ``-_FAR`` where none
    does). The dense kernel's form of what :func:`solve_rows` computes from :class:`RowCoeffs`
    (the oracle, :func:`~ipf_jax.likelihood.model_mask.model_mask`, has its own)."""
    first = xp.full(py.shape, _FAR, xp.int32)
    last = xp.full(py.shape, -_FAR, xp.int32)
    for k in SIDES:
        ax, ay = qc.quad[:, k, 0][:, None], qc.quad[:, k, 1][:, None]
        bx, by = qc.quad[:, (k + 1) % 4, 0][:, None], qc.quad[:, (k + 1) % 4, 1][:, None]
        rise = by - ay
        # the side's line on row py: q j rise = ax rise + (bx - ax) (py - ay)
        num, den = ax * rise + (bx - ax) * (py - ay), q * rise
        num, den = xp.where(den < 0, -num, num), xp.maximum(xp.abs(den), 1)
        crosses = (qc.quad_on[:, None] & (rise != 0) & (py >= xp.minimum(ay, by))
                   & (py <= xp.maximum(ay, by)))
        first = xp.where(crosses, xp.minimum(first, -((-num) // den)), first)
        last = xp.where(crosses, xp.maximum(last, num // den), last)
    return first.astype(xp.int32), last.astype(xp.int32)


def dense_interval_stage(caps, win_rows, win_words, n_win: int, n_win_words: int, q: int,
                         long_side: int, height, width):
    """Dense kernel, stage 1: the same (S, R) packed intervals by testing every window pixel
    against the discs (:func:`discs_inside`), with the sides' crossings of each row
    (:func:`side_crossings`) and the ends of the discs' chords that hold no pixel centre or run
    past the image (the window holds the image's pixels only). win_words : (S,) int32 first
    word of each window;  n_win_words : Wd (static). Each row's interval runs from the leftmost to
    the rightmost candidate (the row-convex rule of :func:`solve_rows`).
    """
    qc = quantize(jnp, caps, q, long_side)
    rows = _window_rows(win_rows, n_win)  # (S, R)
    cols = win_words[:, None] * WORD + jnp.arange(n_win_words * WORD, dtype=jnp.int32)  # (S, X)
    inside = discs_inside(qc, cols[:, None, :] * q, rows[:, :, None] * q)
    inside = inside & (cols < width)[:, None, :]
    col = jnp.broadcast_to(cols[:, None, :], inside.shape)
    # one variadic reduction: two separate ones would make XLA materialise the pixel tests
    lo, hi = jax.lax.reduce((jnp.where(inside, col, _FAR), jnp.where(inside, col, -1)),
                            (np.int32(_FAR), np.int32(-1)),
                            lambda a, b: (jnp.minimum(a[0], b[0]), jnp.maximum(a[1], b[1])), (2,))
    for k in range(2):  # chords the window's pixels cannot show: past the image, or holding none
        cx, cy, r = (qc.disc[:, k, i][:, None] for i in range(3))
        m = jnp.where(qc.drawn[:, None], r * r - jnp.clip(rows * q - cy, -_BIG, _BIG) ** 2, -1)
        s = _isqrt(jnp, m)
        c_lo, c_hi = -((s - cx) // q), (cx + s) // q
        unseen = (m >= 0) & ((c_lo > c_hi) | (c_lo < 0) | (c_hi >= width))
        lo = jnp.where(unseen, jnp.minimum(lo, jnp.clip(c_lo, -1, width)), lo)
        hi = jnp.where(unseen, jnp.maximum(hi, jnp.clip(c_hi, -1, width)), hi)
    first, last = side_crossings(qc, rows * q, q)
    lo = jnp.minimum(lo, jnp.clip(first, -1, width))
    hi = jnp.maximum(hi, jnp.clip(last, -1, width))
    return pack_intervals(jnp.minimum(lo, width), hi, rows, height, width)


def _bits_between(a, b):
    """uint32 with bits a .. b-1 set, 0 <= a <= b <= 32.

    XLA defines a shift by the full width (32) as 0, so ``ALL << a`` holds bits a .. 31 for every
    a in 0 .. 32 and the XOR of two of them is the run between (no selects).
    """
    full = jnp.uint32(0xFFFFFFFF)
    return (full << a.astype(jnp.uint32)) ^ (full << b.astype(jnp.uint32))


class Roi(NamedTuple):
    """The union grid: ``rows`` x ``words`` (static sizes) starting at (row0, word0) (dynamic)."""

    row0: jnp.ndarray
    word0: jnp.ndarray


#: A packed interval holding no column (:func:`pack_intervals` of lo = 0, hi = -1).
EMPTY = 1 << 12


def window_bits(packed, win_word, n_win_words: int):
    """(R, B) packed intervals of one capsule's window -> (Wd, R, B) uint32 bit words."""
    lo, hi = unpack_intervals(packed)
    base = ((win_word + jnp.arange(n_win_words, dtype=jnp.int32)) * WORD)[:, None, None]
    a = jnp.clip(lo[None] - base, 0, WORD)
    b = jnp.clip(hi[None] + 1 - base, 0, WORD)
    return _bits_between(a, jnp.maximum(a, b))


def batch_words(packed, rows: RowList, sil_words, roi: Roi, win_rows, win_words, n_win: int,
                n_win_words: int, n_rows: int, n_words: int):
    """Stage 2, particle axis last: (T, B) packed intervals of a :class:`RowList` -> (Nc, Nm_total),
    each (B,) int32, against one bit-packed mask.

    Each capsule's R x Wd window of bit words (its list entries, the rest of the window empty) is
    ORed into the union grid (words, rows, particles), ANDed with the mask's words and counted with
    ``population_count``. The window offsets are shared by all particles, so every update is a
    plain dynamic slice whose innermost axis, the particles, is whole: the loops vectorise without
    tails or unaligned starts (with rows innermost this stage took twice as long:
    docs/benchmarks.md).
    """
    held = jnp.arange(n_win, dtype=jnp.int32)[:, None]

    def add(s, grid):  # one in-place update per capsule
        window = jax.lax.dynamic_slice_in_dim(packed, rows.first[s], n_win)  # (R, B)
        own = (held >= rows.skip[s]) & (held < rows.skip[s] + rows.count[s])
        bits = window_bits(jnp.where(own, window, EMPTY), win_words[s], n_win_words)
        pos = (win_words[s] - roi.word0, win_rows[s] - roi.row0, 0)
        old = jax.lax.dynamic_slice(grid, pos, bits.shape)
        return jax.lax.dynamic_update_slice(grid, old | bits, pos)

    # a loop, not unrolled: the offsets are data either way, and one body compiles about 3x faster
    grid = jax.lax.fori_loop(0, win_rows.shape[0], add,
                             jnp.zeros((n_words, n_rows, packed.shape[-1]), jnp.uint32))
    sil = jax.lax.dynamic_slice(sil_words, (roi.row0, roi.word0), (n_rows, n_words)).T[..., None]
    # both counts in one pass: per row they stay below 2**16 (at most 64 words of 32 bits)
    both = (jax.lax.population_count(grid & sil).astype(jnp.int32)
            + (jax.lax.population_count(grid).astype(jnp.int32) << 16))
    per_row = jnp.sum(both, axis=0)  # (rows, B)
    return jnp.sum(per_row & 0xFFFF, axis=0), jnp.sum(per_row >> 16, axis=0)


def word_stage(packed, sil_words, roi: Roi, win_rows, win_words, n_win_words: int, n_rows: int,
               n_words: int):
    """Stage 2, one capsule set: (S, R) packed intervals on each capsule's window -> (Nc, Nm_total)
    int32 scalars (:func:`batch_words` with one particle)."""
    n_win = packed.shape[1]
    nc, nm = batch_words(packed.reshape(-1, 1), window_list(win_rows, n_win), sil_words, roi,
                         win_rows, win_words, n_win, n_win_words, n_rows, n_words)
    return nc[0], nm[0]


def _whole_roi(caps, roi: Roi):
    s = caps.shape[0]
    return jnp.full((s,), roi.row0, jnp.int32), jnp.full((s,), roi.word0, jnp.int32)


def scanline_counts(caps, sil_words, roi: Roi, n_rows: int, n_words: int, q: int, long_side: int,
                    height, width):
    """(Nc, Nm_total) for one capsule set against one bit-packed mask, every capsule's window
    being the whole ROI (the scorer uses tighter windows: same math, less work).

    caps : (S, 15) float32 records.  sil_words : (H_pad, W_words) uint32 packed mask.
    The ROI must hold every in-image model pixel. Returns int32 scalars: pixels in model & mask,
    pixels in model.
    """
    win_rows, win_words = _whole_roi(caps, roi)
    packed = interval_stage(caps, win_rows, n_rows, q, long_side, height, width)
    return word_stage(packed, sil_words, roi, win_rows, win_words, n_words, n_rows, n_words)


def dense_counts(caps, sil_words, roi: Roi, n_rows: int, n_words: int, q: int, long_side: int,
                 height, width):
    """Same contract as :func:`scanline_counts`, by testing every ROI pixel against the discs
    (:func:`dense_interval_stage`)."""
    win_rows, win_words = _whole_roi(caps, roi)
    packed = dense_interval_stage(caps, win_rows, win_words, n_rows, n_words, q, long_side,
                                  height, width)
    return word_stage(packed, sil_words, roi, win_rows, win_words, n_words, n_rows, n_words)


def pack_rows(mask: np.ndarray, n_words: int | None = None) -> np.ndarray:
    """Bit-pack a (H, W) boolean mask into (H, W_words) uint32 (bit b of word k = column 32k+b)."""
    h, w = mask.shape
    n_words = n_words or -(-w // WORD)
    padded = np.zeros((h, n_words * WORD), bool)
    padded[:, :w] = mask
    return np.packbits(padded, axis=1, bitorder="little").view("<u4").astype(np.uint32)
