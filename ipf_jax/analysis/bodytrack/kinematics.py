"""bodytrack's forward kinematics (BodyGeometry::ComputeGeometry), re-derived in NumPy float64.

A pose (31,) and a :class:`~ipf_jax.analysis.bodytrack.io.BodytrackShape` give 10 truncated cones and
named points in the world frame of the ``.cal`` files, converted to **metres**. See the package
docstring for the convention; the chain below follows it transform by transform.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ...errors import require
from .io import NUM_PARTS, NUM_POSE, BodytrackShape

MM = 1e-3  # bodytrack works in millimetres; ipf-jax in metres

#: Points bodytrack's model defines, named like ipf-jax's where one exists. ``sacrum`` is the
#: pelvis origin (at hip-joint height, between the hips, not the anatomical sacrum); ``neck`` is
#: the thorax origin, the torso length from the pelvis origin along the thorax (the torso cone
#: itself is rigid with the pelvis, so its top meets ``neck`` only at zero thorax angles);
#: ``head`` is the base of the head cone, the same place as ``neck``; ``head_top`` is the far end
#: of the head cone.
POINT_NAMES: tuple[str, ...] = (
    "sacrum",
    "left_hip", "left_knee", "left_ankle",
    "right_hip", "right_knee", "right_ankle",
    "neck", "head", "head_top",
    "left_shoulder", "left_elbow", "left_wrist",
    "right_shoulder", "right_elbow", "right_wrist",
)
POINT_INDEX = {n: i for i, n in enumerate(POINT_NAMES)}

# The fixed 3x3 rotations of BodyGeometry.h, by their bodytrack names. Note "XRot90" turns by -90
# degrees about x in the right-handed convention and "XRot270" by +90; kept as written there.
_XROT90 = np.array([[1.0, 0, 0], [0, 0, 1], [0, -1, 0]])
_XROT180 = np.diag([1.0, -1, -1])
_XROT270 = np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]])
_YROT90 = np.array([[0.0, 0, -1], [0, 1, 0], [1, 0, 0]])
_YROT180 = np.diag([-1.0, 1, -1])
_ZROT180 = np.diag([-1.0, -1, 1])
# re-orients the clavicle frame into the upper-arm frame (both arms)
_SHOULDER = _XROT90 @ _ZROT180 @ _YROT90


def euler_zxy(a: float, b: float, c: float) -> np.ndarray:
    """(3, 3) bodytrack joint rotation E(a, b, c) = Rz(c) Rx(a) Ry(b)."""
    ca, sa, cb, sb, cc, sc = np.cos(a), np.sin(a), np.cos(b), np.sin(b), np.cos(c), np.sin(c)
    rx = np.array([[1, 0, 0], [0, ca, -sa], [0, sa, ca]])
    ry = np.array([[cb, 0, sb], [0, 1, 0], [-sb, 0, cb]])
    rz = np.array([[cc, -sc, 0], [sc, cc, 0], [0, 0, 1]])
    return rz @ rx @ ry


def _rot(R: np.ndarray) -> np.ndarray:
    H = np.eye(4)
    H[:3, :3] = R
    return H


def _shift(x: float, y: float, z: float) -> np.ndarray:
    H = np.eye(4)
    H[:3, 3] = (x, y, z)
    return H


def _child(a: float, b: float, c: float) -> np.ndarray:
    # bodytrack stores each joint as parent-in-child, so the chain multiplies by its inverse
    return _rot(euler_zxy(a, b, c).T)


class BodytrackParts(NamedTuple):
    """The 10 cones of one pose (world frame, metres), in :data:`~ipf_jax.analysis.bodytrack.io.PART_NAMES` order.

    frames : (10, 4, 4) each cone's rigid frame (no x/y scaling); the cone runs along local z from
        0 to ``length``.
    length : (10,) signed length; negative for the four arm parts, which bodytrack grows along -z.
    a, b : (10, 3) centres of the bottom (z = 0) and top (z = length) end discs.
    radii : (10, 2) bottom and top radius.
    scale : (10, 2) cross-section scale of local x and y (elliptic torso and head).
    """

    frames: np.ndarray
    length: np.ndarray
    a: np.ndarray
    b: np.ndarray
    radii: np.ndarray
    scale: np.ndarray


class BodytrackGeometry(NamedTuple):
    """points : (J, 3) metres, in :data:`POINT_NAMES` order;  parts : :class:`BodytrackParts`."""

    points: np.ndarray
    parts: BodytrackParts


def bodytrack_geometry(pose: np.ndarray, shape: BodytrackShape) -> BodytrackGeometry:
    """Forward kinematics of one bodytrack pose.

    Parameters
    ----------
    pose : (31,) bodytrack pose (radians; pelvis position in mm).
    shape : the subject's :class:`~ipf_jax.analysis.bodytrack.io.BodytrackShape`.

    Returns
    -------
    :class:`BodytrackGeometry` in the world frame of the ``.cal`` files, metres.
    """
    v = np.asarray(pose, np.float64)
    require(v.shape == (NUM_POSE,), f"a bodytrack pose has {NUM_POSE} numbers, got shape {v.shape}")
    L = np.asarray(shape.lengths, np.float64)  # mm

    pelvis = _rot(euler_zxy(v[0], v[1], v[2]))
    pelvis[:3, 3] = v[3:6]

    # legs hang from the pelvis turned 180 deg about y (local z points down), offset sideways
    l_hip = pelvis @ _rot(_YROT180) @ _shift(0, L[1], 0)
    l_thigh = l_hip @ _child(v[6], v[7], v[8])
    l_knee = l_thigh @ _shift(0, 0, L[2])
    l_shin = l_knee @ _child(0, v[9], 0)
    r_hip = pelvis @ _rot(_YROT180) @ _shift(0, -L[5], 0)
    r_thigh = r_hip @ _child(v[10], v[11], v[12])
    r_knee = r_thigh @ _shift(0, 0, L[6])
    r_shin = r_knee @ _child(0, v[13], 0)

    # the thorax frame points down (z) from the top of the torso
    thorax = pelvis @ _rot(_XROT180) @ _child(0, v[26], v[27]) @ _shift(0, 0, -L[0])
    l_clav = thorax @ _rot(_XROT90) @ _child(v[14], v[15], 0) @ _shift(0, 0, -L[9])
    l_upper = l_clav @ _rot(_SHOULDER) @ _child(v[16], v[17], v[18])
    l_fore = l_upper @ _shift(0, 0, -L[10]) @ _child(0, v[19], 0)
    r_clav = thorax @ _rot(_XROT270) @ _child(v[20], v[21], 0) @ _shift(0, 0, -L[13])
    r_upper = r_clav @ _rot(_SHOULDER) @ _child(v[22], v[23], v[24])
    r_fore = r_upper @ _shift(0, 0, -L[14]) @ _child(0, v[25], 0)
    head = thorax @ _rot(_XROT180) @ _child(v[28], v[29], v[30])

    frames = np.stack([pelvis, l_thigh, l_shin, r_thigh, r_shin,
                       l_upper, l_fore, r_upper, r_fore, head])  # (10, 4, 4) mm
    length = np.array([L[0], L[2], L[3], L[6], L[7], -L[10], -L[11], -L[14], -L[15], L[17]])
    a = frames[:, :3, 3]
    b = a + frames[:, :3, 2] * length[:, None]

    def at(frame: np.ndarray, z: float = 0.0) -> np.ndarray:
        return frame[:3, 3] + frame[:3, 2] * z

    points = np.stack([
        at(pelvis),
        at(l_hip), at(l_knee), at(l_shin, L[3]),
        at(r_hip), at(r_knee), at(r_shin, L[7]),
        at(thorax), at(head), at(head, L[17]),
        at(l_clav), at(l_fore), at(l_fore, -L[11]),
        at(r_clav), at(r_fore), at(r_fore, -L[15]),
    ]) * MM  # (J, 3)

    frames_m = frames.copy()
    frames_m[:, :3, 3] *= MM
    limbs = np.asarray(shape.limbs, np.float64)
    parts = BodytrackParts(frames_m, length * MM, a * MM, b * MM, limbs[:, :2] * MM,
                           limbs[:, 2:4].copy())
    assert parts.frames.shape == (NUM_PARTS, 4, 4)
    return BodytrackGeometry(points, parts)


def bodytrack_points(pose: np.ndarray, shape: BodytrackShape) -> dict[str, np.ndarray]:
    """One pose (31,) -> {name: (3,) world metres} for every name in :data:`POINT_NAMES`."""
    pts = bodytrack_geometry(pose, shape).points
    return {n: pts[i] for i, n in enumerate(POINT_NAMES)}


def bodytrack_points_batch(poses: np.ndarray, shape: BodytrackShape) -> np.ndarray:
    """poses : (F, 31) -> (F, J, 3) world metres, points in :data:`POINT_NAMES` order."""
    poses = np.asarray(poses, np.float64)
    require(poses.ndim == 2 and poses.shape[1] == NUM_POSE,
            f"poses must have shape (F, {NUM_POSE}), got {poses.shape}")
    return np.stack([bodytrack_geometry(p, shape).points for p in poses])
