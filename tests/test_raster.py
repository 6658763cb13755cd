"""The raster stage is exact: JAX scanline == JAX dense == NumPy reference, pixel for pixel counts."""
import math

import cv2
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from ipf_jax.geometry.capsule2d import capsule_outline
from ipf_jax.likelihood.model_mask import model_mask
from ipf_jax.likelihood.raster import (
    WORD,
    Roi,
    dense_counts,
    dense_interval_stage,
    interval_stage,
    pack_rows,
    quant_scale,
    scanline_counts,
    segment_extent,
    word_stage,
)
from ipf_jax.reference.raster import counts_from_caps


def random_caps(rng, n_sets, height, width, n_seg=17):
    """Random capsule records: inside, straddling the border, outside, tiny, nested, hidden."""
    L = max(height, width)
    c0 = rng.uniform(-0.3 * L, [1.3 * width, 1.3 * height], size=(n_sets, n_seg, 2))
    c1 = c0 + rng.normal(0, 0.2 * L, size=(n_sets, n_seg, 2))
    r0 = rng.choice([0.0, 0.05, 0.4, 1.5, 4.0, 12.0, 40.0], size=(n_sets, n_seg)) * rng.uniform(0.5, 1.5, (n_sets, n_seg))
    r1 = rng.choice([0.0, 0.3, 3.0, 9.0, 30.0], size=(n_sets, n_seg)) * rng.uniform(0.5, 1.5, (n_sets, n_seg))
    nested = rng.random((n_sets, n_seg)) < 0.05
    c1[nested] = c0[nested] + 0.5
    drawn = rng.random((n_sets, n_seg)) > 0.05
    return capsule_outline(np, c0, r0, c1, r1, drawn)


def far_caps(height, width):
    """Capsules far outside the image with huge radii: clipped to the guard band, they reach in."""
    L = max(height, width)
    c0 = np.array([[5.0 * L, 0.5 * height], [0.5 * width, -4.0 * L], [-3.0 * L, 3.0 * L]])
    c1 = c0 + np.array([[1.0 * L, 0.3 * L], [0.2 * L, -0.5 * L], [0.0, 0.0]])
    r = np.array([3.5 * L, 2.2 * L, 4.0 * L])
    return capsule_outline(np, c0, r, c1, 0.5 * r, np.ones(3, bool))


def counts_all(caps, mask, kernel):
    h, w = mask.shape
    q = quant_scale(h, w)
    words = jnp.asarray(pack_rows(mask))
    n_words = words.shape[1]
    f = scanline_counts if kernel == "scanline" else dense_counts
    run = jax.jit(jax.vmap(lambda c: jnp.stack(f(c, words, Roi(jnp.int32(0), jnp.int32(0)), h,
                                                  n_words, q, max(h, w), jnp.int32(h), jnp.int32(w)))))
    nc_nm = np.asarray(run(jnp.asarray(caps)))
    nc, nm = nc_nm[:, 0].astype(np.int64), nc_nm[:, 1].astype(np.int64)
    return np.stack([nc, mask.sum() - nc, nm - nc], -1)


@pytest.mark.parametrize("height, width", [(60, 80), (45, 100)])
def test_scanline_dense_reference_agree_exactly_on_random_capsules(height, width):
    rng = np.random.default_rng(height)
    caps = random_caps(rng, 48, height, width)
    mask = rng.random((height, width)) < 0.3
    expected = np.array([counts_from_caps(c, mask) for c in caps])
    np.testing.assert_array_equal(counts_all(caps, mask, "scanline"), expected)
    np.testing.assert_array_equal(counts_all(caps, mask, "dense"), expected)


def test_axis_aligned_capsules_with_flat_quad_edges_are_exact():
    """Equal radii along a row or a column give the quad horizontal edges, which the scanline
    solve handles apart (a gate on the quad's rows): on and between pixel centres, exact."""
    height, width = 40, 56
    rng = np.random.default_rng(5)
    sets = []
    for offset in (0.0, 0.5, 0.125, 0.375):
        c0 = rng.integers(-6, [width + 6, height + 6], size=(17, 2)).astype(float) + offset
        c1 = c0.copy()
        c1[::2, 0] += rng.integers(1, 30, size=9)  # along a row: flat tangent edges
        c1[1::2, 1] += rng.integers(1, 30, size=8)  # along a column: flat chords
        r = rng.choice([0.5, 1.0, 2.5, 6.0], size=17) + offset
        sets.append(capsule_outline(np, c0, r, c1, r, np.ones(17, bool)))
    caps = np.stack(sets)
    mask = rng.random((height, width)) < 0.4
    expected = np.array([counts_from_caps(c, mask) for c in caps])
    np.testing.assert_array_equal(counts_all(caps, mask, "scanline"), expected)


def test_exact_on_real_bodytrack_masks(bodytrack_dir):
    rng = np.random.default_rng(7)
    for k in (1, 3):
        full = cv2.imread(str(bodytrack_dir / f"FG{k}/image0000.bmp"), cv2.IMREAD_GRAYSCALE) > 0
        mask = cv2.resize(full.astype(np.float32), (160, 120), interpolation=cv2.INTER_AREA) >= 0.5
        caps = random_caps(rng, 24, 120, 160)
        expected = np.array([counts_from_caps(c, mask) for c in caps])
        np.testing.assert_array_equal(counts_all(caps, mask, "scanline"), expected)


def test_full_resolution_counts_partition_the_mask(bodytrack_dir):
    mask = cv2.imread(str(bodytrack_dir / "FG2/image0000.bmp"), cv2.IMREAD_GRAYSCALE) > 0
    caps = random_caps(np.random.default_rng(3), 4, 480, 640)
    got = counts_all(caps, mask, "scanline")
    assert np.all(got[:, 0] + got[:, 1] == int(mask.sum()))
    for c, row in zip(caps, got):  # and Nc + Nm is the model's own pixel count
        assert row[0] + row[2] == int(model_mask(c, 480, 640).sum())


def test_row_fill_is_convex_per_capsule():
    caps = random_caps(np.random.default_rng(11), 6, 50, 70, n_seg=1)
    for c in caps:
        m = model_mask(c, 50, 70)
        for row in m:
            cols = np.nonzero(row)[0]
            if len(cols):
                assert cols[-1] - cols[0] + 1 == len(cols)


def test_disc_area_close_to_pi_r_squared():
    rec = capsule_outline(np, np.array([50.0, 40.0]), np.float64(20.0), np.array([50.0, 40.0]),
                          np.float64(20.0), np.True_)
    area = model_mask(rec[None], 80, 100).sum()
    assert abs(area - np.pi * 400) < 0.02 * np.pi * 400


def test_extent_bounds_every_pixel_even_after_guard_band_clipping():
    h, w = 50, 70
    caps = np.concatenate([random_caps(np.random.default_rng(5), 30, h, w, n_seg=1)[:, 0],
                           far_caps(h, w)])
    ext = segment_extent(np, caps, max(h, w))
    assert np.any(model_mask(far_caps(h, w)[:1], h, w))  # the far capsule does reach in
    for rec, (r0, r1, c0, c1) in zip(caps, ext):
        rows, cols = np.nonzero(model_mask(rec[None], h, w))
        if len(rows):
            assert r0 <= rows.min() and rows.max() <= r1 and c0 <= cols.min() and cols.max() <= c1


_H, _W = 40, 56
_L = max(_H, _W)
_coord = st.floats(-3.0 * _L, 4.0 * _L, width=32)
_radius = st.one_of(st.floats(0.0, 8.0, width=32), st.floats(0.0, 4.0 * _L, width=32))


@settings(max_examples=150, deadline=None)
# an upright capsule wider than the image, centred right of it: its discs, clipped to a radius of
# the long side, start at column 21; its quad, its corners clipped to the guard band, covers
# columns 0-20 too (a box of the discs with the raster's clipped radii misses them; the extent's
# radii are clipped to twice the long side)
@example(x0=78.4, y0=0.0, r0=112.0, dx=0.0, dy=40.0, r1=112.0)
@given(x0=_coord, y0=_coord, r0=_radius, dx=st.floats(-_L, _L, width=32), dy=st.floats(-_L, _L, width=32),
       r1=_radius)
def test_the_box_bounds_every_pixel_of_any_capsule_and_is_tight_inside(x0, y0, r0, dx, dy, r1):
    """The extent holds every pixel of the quantised capsule wherever it is and however the guard
    band clips it (far outside, radii beyond the image), and for a capsule inside the image, of
    discs a pixel wide or more, it is within 3 pixels of the pixels' own box (the one-pixel margin,
    rounding up, and the pixel centres inside the edge): windows hold everything, and not much
    more."""
    rec = capsule_outline(np, np.array([x0, y0]), np.float64(r0), np.array([x0 + dx, y0 + dy]),
                          np.float64(r1), np.True_).astype(np.float32)
    r_lo, r_hi, c_lo, c_hi = segment_extent(np, rec[None], _L)[0]
    rows, cols = np.nonzero(model_mask(rec[None], _H, _W))
    if not len(rows):
        return
    assert r_lo <= rows.min() and rows.max() <= r_hi and c_lo <= cols.min() and cols.max() <= c_hi
    xs, ys, rs = rec[[0, 3]], rec[[1, 4]], rec[[2, 5]]
    inside = (np.all(xs - rs >= 0) and np.all(xs + rs <= _W - 1) and np.all(ys - rs >= 0)
              and np.all(ys + rs <= _H - 1))
    if inside and np.all(rs >= 1):  # discs of a pixel or more reach within a pixel of their edge
        assert rows.min() - r_lo <= 3 and r_hi - rows.max() <= 3
        assert cols.min() - c_lo <= 3 and c_hi - cols.max() <= 3


@pytest.mark.parametrize("kernel", ["scanline", "dense"])
def test_windowed_kernels_are_exact_wherever_the_windows_sit(kernel):
    """Any windows holding each capsule's pixels give the reference's counts (random placement)."""
    h, w = 60, 80
    rng = np.random.default_rng(21)
    caps = np.concatenate([random_caps(rng, 24, h, w, n_seg=6), np.repeat(far_caps(h, w)[None], 24, 0)],
                          axis=1)  # (24, 9, 15)
    mask = rng.random((h, w)) < 0.4
    ext = segment_extent(np, caps, max(h, w)).astype(np.int64)  # (N, S, 4)
    lo_r, hi_r = np.clip(ext[..., 0].min(0), 0, h - 1), np.clip(ext[..., 1].max(0), 0, h - 1)
    lo_w, hi_w = np.clip(ext[..., 2].min(0), 0, w - 1) // WORD, np.clip(ext[..., 3].max(0), 0, w - 1) // WORD
    n_win = min(h, int(np.max(hi_r - lo_r + 1)) + 3)
    n_win_words = int(np.max(hi_w - lo_w + 1))
    words = pack_rows(mask)
    n_words = words.shape[1]
    # a random start that keeps [lo, hi] inside the window and the window inside the image
    win_rows = rng.integers(np.maximum(hi_r - n_win + 1, 0), np.minimum(lo_r, h - n_win) + 1)
    win_words = rng.integers(np.maximum(hi_w - n_win_words + 1, 0),
                             np.minimum(lo_w, n_words - n_win_words) + 1)
    q = quant_scale(h, w)
    wr, ww = jnp.asarray(win_rows, jnp.int32), jnp.asarray(win_words, jnp.int32)

    def one(c):
        if kernel == "scanline":
            packed = interval_stage(c, wr, n_win, q, max(h, w), h, w)
        else:
            packed = dense_interval_stage(c, wr, ww, n_win, n_win_words, q, max(h, w), h, w)
        return jnp.stack(word_stage(packed, jnp.asarray(words), Roi(jnp.int32(0), jnp.int32(0)), wr, ww,
                                    n_win_words, h, n_words))

    got = np.asarray(jax.jit(jax.vmap(one))(jnp.asarray(caps)))
    expected = np.array([counts_from_caps(c, mask) for c in caps])
    np.testing.assert_array_equal(got[:, 0], expected[:, 0])
    np.testing.assert_array_equal(got[:, 1] - got[:, 0], expected[:, 2])


def test_row_coeffs_field_by_field_equal_those_of_the_stacks():
    """The scorer quantises field by field (QuantFields); the stacked QuantCaps of the NumPy side
    give the same coefficients, in JAX and in NumPy."""
    from ipf_jax.likelihood.raster import as_fields, quantize, quantize_fields, row_coeffs

    caps = random_caps(np.random.default_rng(7), 6, 120, 160).astype(np.float32)  # (6, 17, 15)
    q, long_side = quant_scale(120, 160), 160
    stacked = quantize(np, caps, q, long_side)
    fields = quantize_fields(np, lambda i: caps[..., i], q, long_side)
    for a, b in zip(jax.tree.leaves(as_fields(stacked)), jax.tree.leaves(fields)):
        np.testing.assert_array_equal(a, b)
    ref = row_coeffs(np, as_fields(stacked), q)
    by_fields = jax.jit(lambda c: row_coeffs(jnp, quantize_fields(jnp, lambda i: c[..., i], q,
                                                                   long_side), q))(caps)
    leaves = jax.tree.leaves(ref)
    assert len(leaves) == 18  # 2 discs x 3, 2 sides x 5, 2 inverse slopes
    for a, b in zip(leaves, jax.tree.leaves(by_fields)):
        np.testing.assert_array_equal(a, np.asarray(b))


def test_pixels_are_those_inside_the_true_capsule_up_to_its_boundary():
    """Capsules of equal radii, many leaving the image sideways: the oracle's pixels (the kernels'
    by the test above) are exactly the pixel centres within the radius of the axis, wherever a
    centre is more than a pixel from the boundary (a side's row from the image's border to the
    side included: the disc beyond the border bounds it)."""
    from ipf_jax.likelihood.model_mask import model_mask

    h, w = 60, 80
    rng = np.random.default_rng(3)
    j, i = np.meshgrid(np.arange(w, dtype=float), np.arange(h, dtype=float))
    for k in range(120):  # one end beyond the left or right border, the other inside
        c0 = np.array([rng.choice([rng.uniform(-30, -5), rng.uniform(w + 5, w + 30)]), rng.uniform(0, h)])
        c1 = rng.uniform([0, 0], [w, h]) if k % 2 else c0 + rng.normal(0, 30, 2)
        r = rng.uniform(2, 12)
        caps = capsule_outline(np, c0[None], np.array([r]), c1[None], np.array([r]), np.ones(1, bool))
        axis = c1 - c0
        t = np.clip(((j - c0[0]) * axis[0] + (i - c0[1]) * axis[1]) / (axis @ axis), 0, 1)
        dist = np.hypot(j - c0[0] - t * axis[0], i - c0[1] - t * axis[1])
        clear = np.abs(dist - r) > 1.0
        drawn = model_mask(caps.astype(np.float32), h, w)
        np.testing.assert_array_equal(drawn[clear], (dist <= r)[clear])


@pytest.mark.parametrize("xp", [np, jnp], ids=["numpy", "jax"])
def test_integer_root_and_rounding_are_exact(xp):
    """The raster's two float shortcuts: ``_isqrt`` is floor(sqrt) on every square's neighbours
    and random values below 2**30 (-1 below 0); ``_rint`` is round-half-even, ties included."""
    from ipf_jax.likelihood.raster import _isqrt, _rint

    rng = np.random.default_rng(7)
    k = np.arange(1 << 15, dtype=np.int64)
    m = np.concatenate([k * k - 1, k * k, k * k + 1, rng.integers(-50, 1 << 30, 200_000)])
    m = m[m < (1 << 30)].astype(np.int32)
    want = np.array([math.isqrt(int(v)) if v >= 0 else -1 for v in m])
    fn = jax.jit(lambda a: _isqrt(jnp, a)) if xp is jnp else (lambda a: _isqrt(np, a))
    np.testing.assert_array_equal(np.asarray(fn(xp.asarray(m))), want)

    x = np.concatenate([rng.uniform(-(1 << 22) + 1, (1 << 22) - 1, 200_000),
                        np.arange(-4000, 4000) + 0.5, np.arange(-4000, 4000) - 0.49999997,
                        [0.0, -0.0, 0.5, -0.5, 1.5, -2.5]]).astype(np.float32)
    fn = jax.jit(lambda a: _rint(jnp, a)) if xp is jnp else (lambda a: _rint(np, a))
    np.testing.assert_array_equal(np.asarray(fn(xp.asarray(x))), np.round(x).astype(np.int32))


@pytest.mark.parametrize("height, width", [(240, 320), (1536, 2048)])
def test_row_solve_equals_exact_integers_on_any_row(height, width):
    """:func:`solve_rows` (int32, float shortcuts) equals the oracle's exact int64 rows
    (:func:`~ipf_jax.likelihood.model_mask.capsule_rows`) on rows inside, beside and far outside
    the image, at both grid scales."""
    from ipf_jax.likelihood.model_mask import capsule_rows
    from ipf_jax.likelihood.raster import as_fields, quantize, row_coeffs, solve_rows

    q, L = quant_scale(height, width), max(height, width)
    caps = np.concatenate([random_caps(np.random.default_rng(3), 40, height, width).reshape(-1, 15),
                           far_caps(height, width)])
    qc = quantize(np, caps.astype(np.float32), q, L)
    rows = np.concatenate([np.arange(-4 * L, 5 * L, max(1, L // 160)), [-10**6, -3 * L - 1, 10**6]])
    lo, hi = solve_rows(row_coeffs(np, as_fields(qc), q), (rows * q).astype(np.int32)[None, :], q,
                        width, lambda a: a[..., None], np)
    row_y = rows.astype(np.int64) * q
    disc, quad = qc.disc.astype(np.int64).tolist(), qc.quad.astype(np.int64).tolist()
    for s in range(len(caps)):
        want_lo, want_hi = (capsule_rows(disc[s], quad[s], bool(qc.quad_on[s]), row_y, q)
                            if qc.drawn[s] else (np.full(len(rows), width), np.full(len(rows), -1)))
        np.testing.assert_array_equal(lo[s], np.clip(want_lo, -1, width), err_msg=f"capsule {s}")
        np.testing.assert_array_equal(hi[s], np.clip(want_hi, -1, width), err_msg=f"capsule {s}")
