"""The vectorised NumPy scanline (the fair NumPy baseline) gives the reference's counts exactly."""
import cv2
import numpy as np
import pytest
from test_raster import far_caps, random_caps

from ipf_jax.body import default_shape
from ipf_jax.geometry.world import up_rotation
from ipf_jax.reference import PIXEL_ATOL, scanline
from ipf_jax.reference import likelihood as ref
from ipf_jax.reference.raster import counts_from_caps
from ipf_jax.viz import synthetic as syn


@pytest.mark.parametrize("height, width", [(60, 80), (45, 100), (33, 37)])
def test_counts_equal_reference_on_random_capsules(height, width):
    rng = np.random.default_rng(height + width)
    caps = random_caps(rng, 40, height, width)
    caps[:4, :3] = far_caps(height, width)  # guard-band clipped capsules reaching into the image
    mask = rng.random((height, width)) < 0.3
    expected = np.array([counts_from_caps(c, mask) for c in caps])
    np.testing.assert_array_equal(scanline.counts_from_caps(caps, mask), expected)


def test_counts_equal_reference_on_a_real_mask(bodytrack_dir):
    full = cv2.imread(str(bodytrack_dir / "FG2/image0000.bmp"), cv2.IMREAD_GRAYSCALE) > 0
    mask = cv2.resize(full.astype(np.float32), (160, 120), interpolation=cv2.INTER_AREA) >= 0.5
    caps = random_caps(np.random.default_rng(9), 16, 120, 160)
    expected = np.array([counts_from_caps(c, mask) for c in caps])
    np.testing.assert_array_equal(scanline.counts_from_caps(caps, mask), expected)


def test_nothing_visible_gives_zero_model():
    mask = np.zeros((20, 30), bool)
    mask[5:9, 4:12] = True
    caps = random_caps(np.random.default_rng(1), 3, 20, 30)
    caps[..., 14] = 0.0  # nothing drawn (behind the camera)
    np.testing.assert_array_equal(scanline.counts_from_caps(caps, mask), [[0, 32, 0]] * 3)


def test_vectorised_geometry_and_pipeline_match_the_reference():
    shape, up = default_shape(), up_rotation("+z")
    cams = syn.ring_cameras(2, width=80, height=60, focal_px=75)
    q = syn.procedural_walk(3, shape=shape)
    masks = list(syn.render_masks(q, shape, cams)[1])
    particles = q[1] + np.random.default_rng(2).normal(0, 0.05, size=(12, q.shape[1]))
    caps = scanline.project_capsules(particles, shape.values, up, cams)  # (N, C, S, 15)
    for n, p in enumerate(particles):
        np.testing.assert_allclose(caps[n], ref.project_capsules(p, shape.values, up, cams),
                                   atol=PIXEL_ATOL)
    got = scanline.counts(particles, shape.values, up, cams, masks, chunk=5)
    want = ref.counts(particles, shape.values, up, cams, masks)
    # float64 geometry on both sides, but FK by another route: a boundary pixel may flip
    assert np.abs(got - want).max() <= 2 and np.mean(got == want) > 0.9
