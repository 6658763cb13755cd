"""Reference projection, float64, one point at a time in spirit (vectorised only over points)."""
from __future__ import annotations

import numpy as np

from ..geometry.camera import Z_NEAR, Camera


def project_points(cam: Camera, X: np.ndarray):
    """X : (..., 3) world metres -> uv (..., 2), depth z (...,), radial magnification (...,)."""
    X = np.asarray(X, float)
    Xc = X @ cam.R.T + cam.T
    z = Xc[..., 2]
    zs = np.where(z > Z_NEAR, z, Z_NEAR)
    x, y = Xc[..., 0] / zs, Xc[..., 1] / zs
    r = np.hypot(x, y)
    r_max = cam.r_max()
    s = np.where(r > r_max, r_max / np.maximum(r, 1e-12), 1.0)
    x, y = x * s, y * s
    k1, k2, p1, p2, k3 = cam.dist
    r2 = x * x + y * y
    radial = 1 + k1 * r2 + k2 * r2**2 + k3 * r2**3
    xd = (x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x)) / s
    yd = (y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y) / s
    u = cam.K[0, 0] * xd + cam.K[0, 1] * yd + cam.K[0, 2]
    v = cam.K[1, 1] * yd + cam.K[1, 2]
    return np.stack([u, v], -1), z, radial


def project_spheres(cam: Camera, centres: np.ndarray, radii: np.ndarray):
    """Spheres -> discs: uv (..., 2), r_px (...,), in_front (...,) bool."""
    uv, z, mag = project_points(cam, centres)
    f = 0.5 * (cam.K[0, 0] + cam.K[1, 1])
    return uv, f * np.asarray(radii) / np.maximum(z, Z_NEAR) * mag, z > Z_NEAR
