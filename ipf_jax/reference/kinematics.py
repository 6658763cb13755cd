"""Reference forward kinematics: 4x4 homogeneous transforms walked down the tree, float64."""
from __future__ import annotations

import numpy as np

from ..body.model import DOF_INDEX, FRAMES, POINTS, SEGMENTS, SHAPE_INDEX, parse_coord
from ..geometry.kinematics import Pose3D


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


def forward_kinematics(q, shape_values, up) -> Pose3D:
    """q : (D,), shape_values : (P,), up : (3, 3) -> Pose3D of float64 arrays (one particle)."""
    q = np.asarray(q, float)
    shape_values = np.asarray(shape_values, float)
    world: dict[str, np.ndarray] = {}
    for f in FRAMES:
        R = np.eye(3)
        for axis, sign, dof in f.rotation:
            R = R @ _rotation(axis, sign * q[DOF_INDEX[dof]])
        if f.parent is None:
            world[f.name] = _homogeneous(np.asarray(up, float) @ R, q[:3])
        else:
            world[f.name] = world[f.parent] @ _homogeneous(R, _vector(f.origin, shape_values))

    def place(frame, coords):
        return (world[frame] @ np.append(_vector(coords, shape_values), 1.0))[:3]

    points = np.array([place(p.frame, p.position) for p in POINTS])
    seg_a = np.array([place(s.frame, s.a) for s in SEGMENTS])
    seg_b = np.array([place(s.frame, s.b) for s in SEGMENTS])
    seg_r = np.array([[shape_values[SHAPE_INDEX[s.r_a]], shape_values[SHAPE_INDEX[s.r_b]]]
                      for s in SEGMENTS])
    return Pose3D(points, seg_a, seg_b, seg_r)
