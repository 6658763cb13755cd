"""Projection (JAX vs NumPy reference), distortion guards, and 2D capsule outlines."""
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from ipf_jax.geometry import host as ref
from ipf_jax.geometry.camera import Camera, project_points, stack_cameras
from ipf_jax.geometry.capsule2d import capsule_outline
from ipf_jax.reference import PIXEL_ATOL
from ipf_jax.viz.synthetic import look_at_camera


def distorted_camera():
    cam = look_at_camera([3.0, -2.0, 2.5], [0.0, 0.0, 0.9], width=640, height=480, focal_px=580)
    return Camera(K=cam.K, dist=np.array([-0.32, 0.14, 1e-3, -5e-4, 0.01]), R=cam.R, T=cam.T,
                  width=640, height=480)


def points_in_view(cam, n=200, seed=0):
    rng = np.random.default_rng(seed)
    uv = rng.uniform([20, 20], [cam.width - 20, cam.height - 20], size=(n, 2))
    x = np.linalg.solve(cam.K, np.c_[uv, np.ones(n)].T).T  # undistorted rays are close enough
    depth = rng.uniform(1.5, 6.0, n)
    Xc = x * depth[:, None]
    return (Xc - cam.T) @ cam.R  # world points


def one(cams, c=0):
    return jax.tree_util.tree_map(lambda a: jnp.asarray(a[c]), cams)


def test_jax_projection_matches_reference():
    cam = distorted_camera()
    X = points_in_view(cam)
    uv, z, mag = project_points(one(stack_cameras([cam])), jnp.asarray(X, jnp.float32))
    uv_r, z_r, mag_r = ref.project_points(cam, X)
    np.testing.assert_allclose(np.asarray(uv), uv_r, atol=PIXEL_ATOL)
    np.testing.assert_allclose(np.asarray(z), z_r, rtol=1e-5)


def test_far_points_do_not_fold_back_into_the_image():
    cam = distorted_camera()
    centre = cam.centre
    ahead = cam.R[2]
    side = cam.R[0]
    # a ray sweeping from the optical axis out to 80 degrees: u must grow monotonically
    angles = np.deg2rad(np.linspace(0, 80, 200))
    X = centre + 3.0 * (np.cos(angles)[:, None] * ahead + np.sin(angles)[:, None] * side)
    u = ref.project_points(cam, X)[0][:, 0]
    assert np.all(np.diff(u) > 0)


def test_behind_camera_is_flagged():
    cam = distorted_camera()
    X = cam.centre - 2.0 * cam.R[2]
    _, z, _ = ref.project_points(cam, X[None])
    assert z[0] < 0


def test_scaled_camera_keeps_pixel_centres():
    cam = distorted_camera()
    X = points_in_view(cam, 20)
    uv = ref.project_points(cam, X)[0]
    uv_half = ref.project_points(cam.scaled(0.5), X)[0]
    np.testing.assert_allclose(uv_half, (uv + 0.5) * 0.5 - 0.5, atol=1e-9)


@pytest.mark.parametrize("r0, r1", [(5.0, 5.0), (8.0, 3.0), (2.0, 9.0)])
def test_outline_is_the_outer_tangent_quad(r0, r1):
    c0, c1 = np.array([10.0, 20.0]), np.array([60.0, 45.0])
    rec = capsule_outline(np, c0, np.float64(r0), c1, np.float64(r1), np.True_).astype(float)
    t0p, t0m, t1m, t1p = rec[6:8], rec[8:10], rec[10:12], rec[12:14]
    assert rec[14] == 2.0
    for t, c, r in ((t0p, c0, r0), (t0m, c0, r0), (t1m, c1, r1), (t1p, c1, r1)):
        assert np.linalg.norm(t - c) == pytest.approx(r, abs=1e-4)
    for a, b in ((t0p, t1p), (t0m, t1m)):  # each side is tangent to both discs
        d = (b - a) / np.linalg.norm(b - a)
        for c, r in ((c0, r0), (c1, r1)):
            assert abs(d[0] * (c - a)[1] - d[1] * (c - a)[0]) == pytest.approx(r, abs=1e-3)
    centre = (c0 + c1) / 2
    quad = [t0p, t0m, t1m, t1p]
    for k in range(4):  # inside means cross(B - A, P - A) >= 0 for every edge
        a, b = quad[k], quad[(k + 1) % 4]
        assert (b - a)[0] * (centre - a)[1] - (b - a)[1] * (centre - a)[0] > 0


def test_outline_flags_nested_discs_and_hidden_capsules():
    c = np.array([5.0, 5.0])
    nested = capsule_outline(np, c, np.float64(10.0), c + 1, np.float64(2.0), np.True_)
    hidden = capsule_outline(np, c, np.float64(3.0), c + 20, np.float64(3.0), np.False_)
    assert nested[14] == 1.0 and hidden[14] == 0.0
