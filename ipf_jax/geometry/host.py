"""Host geometry in NumPy float64: forward kinematics and projection, one particle at a time.

What the host side of every stage uses: the tracker's written joints, overlays, exports, synthetic
data, the bodytrack fit. It is the plain textbook form (4x4 homogeneous transforms walked down the
tree, the OpenCV distortion model point by point), independent of the JAX kernels
(:mod:`ipf_jax.geometry.kinematics`, :mod:`ipf_jax.geometry.camera`), which the tests check against
it (:mod:`ipf_jax.reference` builds the oracle likelihood on it).
"""
from __future__ import annotations

import functools
from typing import NamedTuple

import numpy as np

from ..body.model import DOF_INDEX, FRAMES, POINTS, SEGMENTS, SHAPE_INDEX, parse_coord
from .camera import Z_NEAR, Camera
from .capsule2d import capsule_outline
from .kinematics import Pose3D

__all__ = ["forward_kinematics", "joint_points", "project_points", "project_spheres", "project_capsules"]


def _rotation(axis: str, angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    if axis == "x":
        return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    if axis == "y":
        return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def _vector(coords, shape_values) -> np.ndarray:
    return np.array([sum(sign * shape_values[i] for sign, i in parse_coord(c)) for c in coords], float)


def _homogeneous(R: np.ndarray, t: np.ndarray) -> np.ndarray:
    H = np.eye(4)
    H[:3, :3] = R
    H[:3, 3] = t
    return H


class _Body(NamedTuple):
    """The shape's part of forward kinematics: every frame's origin in its parent (3,), and every
    point's and capsule end's homogeneous position in its frame (4,); capsule radii (S, 2)."""

    origins: dict[str, np.ndarray]
    points: tuple[tuple[str, np.ndarray], ...]
    seg_a: tuple[tuple[str, np.ndarray], ...]
    seg_b: tuple[tuple[str, np.ndarray], ...]
    seg_r: np.ndarray


@functools.lru_cache(maxsize=32)
def _body(shape_bytes: bytes) -> _Body:
    """:class:`_Body` of float64 shape values given as bytes (a run has one or a few shapes, so
    the terms of every position are summed once per shape, not once per call)."""
    shape_values = np.frombuffer(shape_bytes, float)

    def at(frame, coords):
        return frame, np.append(_vector(coords, shape_values), 1.0)

    return _Body({f.name: _vector(f.origin, shape_values) for f in FRAMES if f.parent is not None},
                 tuple(at(p.frame, p.position) for p in POINTS),
                 tuple(at(s.frame, s.a) for s in SEGMENTS),
                 tuple(at(s.frame, s.b) for s in SEGMENTS),
                 np.array([[shape_values[SHAPE_INDEX[s.r_a]], shape_values[SHAPE_INDEX[s.r_b]]]
                           for s in SEGMENTS]))


def forward_kinematics(q, shape_values, up) -> Pose3D:
    """q : (D,), shape_values : (P,), up : (3, 3) -> Pose3D of float64 arrays (one particle)."""
    body = _body(np.ascontiguousarray(shape_values, float).tobytes())
    world = _world(np.asarray(q, float), body, up)

    def place(placed):
        return np.array([(world[frame] @ h)[:3] for frame, h in placed])

    return Pose3D(place(body.points), place(body.seg_a), place(body.seg_b), body.seg_r.copy())


def joint_points(q, shape_values, up) -> np.ndarray:
    """(J, 3) float64: :func:`forward_kinematics`'s ``points`` alone (the same operations, so the
    same numbers), without placing the capsule ends (the tracker's estimate every frame)."""
    body = _body(np.ascontiguousarray(shape_values, float).tobytes())
    world = _world(np.asarray(q, float), body, up)
    return np.array([(world[frame] @ h)[:3] for frame, h in body.points])


def _world(q: np.ndarray, body: _Body, up) -> dict[str, np.ndarray]:
    """Every frame's 4x4 homogeneous transform to the world, walked down the tree."""
    world: dict[str, np.ndarray] = {}
    for f in FRAMES:
        R = np.eye(3)
        for axis, sign, dof in f.rotation:
            R = R @ _rotation(axis, sign * q[DOF_INDEX[dof]])
        if f.parent is None:
            world[f.name] = _homogeneous(np.asarray(up, float) @ R, q[:3])
        else:
            world[f.name] = world[f.parent] @ _homogeneous(R, body.origins[f.name])
    return world


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


def project_capsules(q, shape_values, up, cameras: list[Camera]) -> np.ndarray:
    """One particle -> (C, S, 15) float32 capsule records."""
    pose = forward_kinematics(q, shape_values, up)
    out = []
    for cam in cameras:
        uv0, r0, in0 = project_spheres(cam, pose.seg_a, pose.seg_r[:, 0])
        uv1, r1, in1 = project_spheres(cam, pose.seg_b, pose.seg_r[:, 1])
        out.append(capsule_outline(np, uv0, r0, uv1, r1, in0 & in1))
    return np.stack(out)
