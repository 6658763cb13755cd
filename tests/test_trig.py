"""The joint angles' cosine and sine as vectorisable arithmetic (ipf_jax.geometry.trig)."""
import jax
import jax.numpy as jnp
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from ipf_jax.geometry.trig import sincos

#: absolute error allowed against float64 (float32 NumPy itself is within 7.1e-8 on these)
TOL = 2e-7

_jit_sincos = jax.jit(lambda x: sincos(jnp, x))


def _check(x):
    x = np.asarray(x, np.float32)
    c, s = (np.asarray(a) for a in _jit_sincos(x))
    x64 = x.astype(np.float64)
    assert np.abs(c - np.cos(x64)).max() <= TOL
    assert np.abs(s - np.sin(x64)).max() <= TOL


def test_dense_sweep_of_the_angles_the_body_uses_and_beyond():
    _check(np.linspace(-100.0, 100.0, 400_001))
    _check(np.linspace(-2 * np.pi, 2 * np.pi, 200_001))


def test_quadrant_boundaries_and_exact_values():
    k = np.arange(-64, 65)
    edges = np.concatenate([k * np.pi / 4, k * np.pi / 2])
    _check(np.concatenate([edges, np.nextafter(edges.astype(np.float32), np.float32(np.inf)),
                           np.nextafter(edges.astype(np.float32), np.float32(-np.inf))]))
    c, s = (np.asarray(a) for a in _jit_sincos(np.zeros(3, np.float32)))
    assert (c == 1).all() and (s == 0).all()


@settings(max_examples=50, deadline=None)
@given(st.lists(st.floats(-50.0, 50.0, width=32), min_size=1, max_size=64))
def test_any_float32_angle(xs):
    _check(xs)


def test_numpy_keeps_its_own_functions():
    x = np.linspace(-3, 3, 101).astype(np.float32)
    c, s = sincos(np, x)
    np.testing.assert_array_equal(c, np.cos(x))
    np.testing.assert_array_equal(s, np.sin(x))
