"""Calibrated pinhole cameras with OpenCV-convention distortion, and their JAX projection.

Model (OpenCV / Bouguet): ``X_cam = R X_world + T`` (metres); ``x = X_cam.x / X_cam.z``, ``y`` likewise;
``r2 = x^2 + y^2``; radial ``1 + k1 r2 + k2 r2^2 + k3 r2^3``; tangential ``p1, p2``;
``u = K[0,0] x_d + K[0,1] y_d + K[0,2]``, ``v = K[1,1] y_d + K[1,2]``. Pixel ``(0, 0)`` is the
*centre* of the top-left pixel, ``u`` grows to the right (columns), ``v`` downwards (rows).

Two guards keep the model sane away from the calibrated field of view (both are part of the model
and implemented identically by the NumPy reference):

* points with ``X_cam.z < Z_NEAR`` are *behind* the camera: their capsules are refused (not drawn);
* beyond the normalised radius ``r_max`` where the radial polynomial stops being monotonic (or 3x
  the image's corner radius, whichever is smaller) the distortion is extended linearly, so far-away
  points cannot fold back into the image.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import NamedTuple

import jax.numpy as jnp
import numpy as np

from ..errors import require

Z_NEAR = 0.05  # metres


@dataclass(frozen=True)
class Camera:
    """One calibrated camera (host-side; arrays are NumPy float64).

    K : (3, 3) intrinsics (pixels).   dist : (5,) k1, k2, p1, p2, k3 (OpenCV order).
    R : (3, 3) world-to-camera rotation.   T : (3,) translation, metres.
    width, height : image size in pixels.
    """

    K: np.ndarray
    dist: np.ndarray
    R: np.ndarray
    T: np.ndarray
    width: int
    height: int
    name: str = "camera"
    source: str = field(default="", compare=False)

    @property
    def centre(self) -> np.ndarray:
        """(3,) camera centre in world coordinates (metres)."""
        return -self.R.T @ self.T

    @property
    def view_dir(self) -> np.ndarray:
        """(3,) unit optical axis in world coordinates."""
        return self.R[2].copy()

    def scaled(self, scale: float) -> "Camera":
        """The same camera seen at ``scale`` times the resolution (pixel-centre convention)."""
        K = self.K.copy()
        K[0, 0] *= scale
        K[0, 1] *= scale
        K[1, 1] *= scale
        K[0, 2] = (K[0, 2] + 0.5) * scale - 0.5
        K[1, 2] = (K[1, 2] + 0.5) * scale - 0.5
        return replace(self, K=K, width=int(round(self.width * scale)),
                       height=int(round(self.height * scale)))

    def r_max(self) -> float:
        """Normalised radius beyond which the distortion is extended linearly (see module doc)."""
        k1, k2, _, _, k3 = self.dist
        corners = np.array([[0, 0], [self.width - 1, 0], [0, self.height - 1],
                            [self.width - 1, self.height - 1]], float)
        fx, fy = self.K[0, 0], self.K[1, 1]
        corner_r = np.max(np.hypot((corners[:, 0] - self.K[0, 2]) / fx,
                                   (corners[:, 1] - self.K[1, 2]) / fy))
        r = np.linspace(0.0, 3.0 * corner_r, 3001)[1:]
        r2 = r * r
        # d/dr [r (1 + k1 r^2 + k2 r^4 + k3 r^6)] must stay positive
        deriv = 1 + 3 * k1 * r2 + 5 * k2 * r2**2 + 7 * k3 * r2**3
        bad = np.nonzero(deriv <= 0.05)[0]
        return float(r[bad[0] - 1] if len(bad) else r[-1])


def validate_camera(cam: Camera, path: str = "") -> Camera:
    """Check a camera's numbers; raises IPFError naming ``path``."""
    require(cam.K.shape == (3, 3) and cam.R.shape == (3, 3) and cam.T.shape == (3,)
            and cam.dist.shape == (5,), "calibration arrays have the wrong shapes", path or None)
    for name, a in (("intrinsics", cam.K), ("distortion", cam.dist), ("rotation", cam.R),
                    ("translation", cam.T)):
        require(bool(np.all(np.isfinite(a))), f"{name} contains non-finite numbers", path or None)
    require(cam.K[0, 0] > 0 and cam.K[1, 1] > 0, "focal lengths must be positive", path or None)
    # the model reads fx, skew, cx, fy, cy only: anything else there would be silently ignored
    require(cam.K[1, 0] == 0 and bool(np.allclose(cam.K[2], [0, 0, 1])),
            "camera matrix is not upper-triangular with last row (0, 0, 1)", path or None)
    det = float(np.linalg.det(cam.R))
    ortho = float(np.abs(cam.R @ cam.R.T - np.eye(3)).max())
    require(abs(det - 1.0) < 1e-3 and ortho < 1e-3,
            f"rotation is not a proper rotation matrix (det {det:.4g}, |RR^T - I| {ortho:.2g})",
            path or None)
    require(cam.width > 0 and cam.height > 0, "image size must be positive", path or None)
    return cam


class CameraArrays(NamedTuple):
    """Cameras stacked for JAX (leading axis C). All float32.

    K : (C, 3, 3)   dist : (C, 5)   R : (C, 3, 3)   T : (C, 3)   r_max : (C,)
    """

    K: jnp.ndarray
    dist: jnp.ndarray
    R: jnp.ndarray
    T: jnp.ndarray
    r_max: jnp.ndarray


def stack_cameras(cameras: list[Camera], dtype=np.float32) -> CameraArrays:
    """Stack host cameras into arrays (NumPy, float32 by default; JAX converts them on first use)."""
    f = dtype
    return CameraArrays(
        K=np.stack([c.K for c in cameras]).astype(f),
        dist=np.stack([c.dist for c in cameras]).astype(f),
        R=np.stack([c.R for c in cameras]).astype(f),
        T=np.stack([c.T for c in cameras]).astype(f),
        r_max=np.array([c.r_max() for c in cameras], f),
    )


def project_points(cam: CameraArrays, X: jnp.ndarray, xp=jnp) -> tuple[jnp.ndarray, jnp.ndarray, jnp.ndarray]:
    """Project world points through ONE camera (unbatched ``cam`` fields).

    X : (..., 3) world points, metres.  ``xp``: array namespace (NumPy for the vectorised baseline).
    Returns uv : (..., 2) pixels, z : (...,) depth (metres), mag : (...,) local radial
    magnification of the distortion (used to scale projected radii).
    """
    u, v, z, mag = project_xyz(cam, X[..., 0], X[..., 1], X[..., 2], xp)
    return xp.stack([u, v], axis=-1), z, mag


def project_xyz(cam: CameraArrays, x, y, z, xp=jnp):
    """:func:`project_points` on coordinate arrays: (u, v, depth, magnification), each the
    broadcast shape of ``x, y, z`` and the camera fields (see :func:`broadcast_cameras`)."""
    X = (x, y, z)
    # R X + T written out: elementwise, so XLA fuses it with the rest (a dot product would not)
    Xc = [cam.R[i, 0] * X[0] + cam.R[i, 1] * X[1] + cam.R[i, 2] * X[2] + cam.T[i]
          for i in range(3)]
    z = Xc[2]
    zs = xp.where(z > Z_NEAR, z, Z_NEAR)
    x = Xc[0] / zs
    y = Xc[1] / zs
    r = xp.sqrt(x * x + y * y)
    # beyond r_max the distortion is extended linearly along the ray
    s = xp.where(r > cam.r_max, cam.r_max / xp.maximum(r, 1e-12), 1.0)
    xs, ys = x * s, y * s
    k1, k2, p1, p2, k3 = (cam.dist[i] for i in range(5))
    r2 = xs * xs + ys * ys
    radial = 1 + r2 * (k1 + r2 * (k2 + r2 * k3))
    xd = xs * radial + 2 * p1 * xs * ys + p2 * (r2 + 2 * xs * xs)
    yd = ys * radial + p1 * (r2 + 2 * ys * ys) + 2 * p2 * xs * ys
    xd, yd = xd / s, yd / s
    u = cam.K[0, 0] * xd + cam.K[0, 1] * yd + cam.K[0, 2]
    v = cam.K[1, 1] * yd + cam.K[1, 2]
    return u, v, z, radial


def broadcast_cameras(cams: CameraArrays, ndim: int) -> CameraArrays:
    """Stacked cameras whose fields index like ONE camera's (``K[0, 0]``, ``dist[i]``...) and
    broadcast as (C, 1 x ``ndim``): all cameras projected in one batched step by
    :func:`project_xyz` on (...) point arrays of ``ndim`` axes."""
    def move(a, own):
        a = jnp.moveaxis(jnp.asarray(a), 0, own)  # camera axis behind the field's own axes
        return a.reshape(a.shape + (1,) * ndim)
    return CameraArrays(move(cams.K, 2), move(cams.dist, 1), move(cams.R, 2), move(cams.T, 1),
                        move(cams.r_max, 0))


def project_spheres(cam: CameraArrays, centres: jnp.ndarray, radii: jnp.ndarray, xp=jnp):
    """Project spheres to discs through ONE camera.

    centres : (..., 3) metres;  radii : (...,) metres.
    Returns uv : (..., 2), r_px : (...,), in_front : (...,) bool.
    The disc radius is ``f r / z`` times the local radial magnification (a sphere's exact image is
    an ellipse; the disc is the model's approximation, shared with the NumPy reference).
    """
    uv, z, mag = project_points(cam, centres, xp)
    f = 0.5 * (cam.K[0, 0] + cam.K[1, 1])
    r_px = f * radii / xp.maximum(z, Z_NEAR) * mag
    return uv, r_px, z > Z_NEAR
