"""The raster stage is exact: JAX scanline == JAX dense == NumPy reference, pixel for pixel counts."""
import cv2
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from ipf_jax.capsule2d import capsule_outline
from ipf_jax.raster import Roi, dense_counts, pack_rows, quant_scale, scanline_counts
from ipf_jax.reference.raster import counts_from_caps, model_mask


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
