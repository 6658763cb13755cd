"""Floor contact (ipf_jax.tracking.contact): particles are moved along up into the allowed height range."""
import numpy as np

from ipf_jax.body.limits import load_limits
from ipf_jax.body.shape import default_shape
from ipf_jax.geometry.world import up_rotation
from ipf_jax.tracking.contact import FloorContact, lowest_heights
from ipf_jax.viz import synthetic as syn


def test_floating_and_sunken_bodies_are_brought_back_and_others_untouched():
    shape = default_shape(1.7)
    U = up_rotation("+z")
    walk = syn.procedural_walk(6, 20.0, shape=shape)  # lowest foot point on the floor
    assert np.allclose(lowest_heights(walk, shape, U), 0.0, atol=2e-3)
    moved = walk.copy()
    moved[:, 2] += np.array([0.5, -0.2, 0.05, 0.0, 0.2, -0.01])
    fc = FloorContact(load_limits("default"), shape, U, -0.03, 0.10)
    out = fc.clip(moved.copy())
    h = lowest_heights(out, shape, U)
    assert np.all(h >= -0.03 - 1e-4) and np.all(h <= 0.10 + 1e-4)
    np.testing.assert_allclose(h[[0, 1, 4]], [0.10, -0.03, 0.10], atol=1e-4)  # clamped to the edges
    np.testing.assert_allclose(out[[2, 3, 5]], moved[[2, 3, 5]], atol=1e-6)  # inside: untouched
    np.testing.assert_allclose(out[:, :2], moved[:, :2])  # only the vertical moves
    np.testing.assert_allclose(out[:, 3:], moved[:, 3:])


def test_compiled_lowest_heights_match_the_float64_reference():
    """The compiled float32 kernel against shape_fit's NumPy float64 placement, on random poses
    (calls of several lengths, padded to powers of two), within 1e-5 m."""
    from ipf_jax.tracking.shape_fit import lowest_heights as reference

    shape = default_shape(1.7)
    U = up_rotation("+z")
    rng = np.random.default_rng(0)
    for n in (1, 63, 65, 300):
        q = rng.normal(0.0, 0.4, (n, 31))
        q[:, :2] = rng.uniform(-2.0, 2.0, (n, 2))
        q[:, 2] = rng.uniform(0.5, 1.5, n)
        values = np.broadcast_to(np.asarray(shape.values, float), (n, len(shape.values)))
        np.testing.assert_allclose(lowest_heights(q, shape, U), reference(q, values, U), atol=1e-5)
