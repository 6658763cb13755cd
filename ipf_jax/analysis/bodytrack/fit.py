"""Compare bodytrack with ipf-jax: joint sets, distances, and fitting our body to its points.

Only the 12 limb joint centres are compared by default (:data:`SHARED_JOINTS`). bodytrack's other
points have no anatomical counterpart in our model: its pelvis origin lies between the hip joints
(our ``sacrum`` sits ``hip_down`` above them), its thorax origin is a pivot 579 mm above that
from which the clavicles leave at free angles, and its head cone starts at that same point.
"""
from __future__ import annotations

from pathlib import Path
from typing import Mapping, NamedTuple, Sequence

import numpy as np
from scipy.optimize import least_squares

from ...body import default_shape, load_limits
from ...body.model import (
    DOF_INDEX,
    DOFS,
    FRAMES,
    LIMB_JOINTS,
    POINT_INDEX,
    POINTS,
    TRANSLATION_DOFS,
)
from ...body.model import POINT_NAMES as OUR_NAMES
from ...errors import require
from ...geometry.host import forward_kinematics
from ...geometry.world import up_rotation
from .io import read_body_shape, read_pose
from .kinematics import POINT_NAMES as PEER_NAMES
from .kinematics import bodytrack_points_batch

#: Joints that mean the same anatomical place in both models (hip, knee, ankle, shoulder, elbow
#: and wrist centres, both sides).
SHARED_JOINTS: tuple[str, ...] = LIMB_JOINTS

_HEIGHT_RANGE = (1.2, 2.2)  # metres: the fitted subject's standing height
_PRIOR = 1e-3  # metres per radian: only keeps DOFs that the points cannot see from wandering


def peer_joints(pose_file: str | Path, shape_file: str | Path) -> tuple[np.ndarray, tuple[str, ...]]:
    """bodytrack poses from a file -> joints (F, J, 3) world metres and their J names."""
    return bodytrack_points_batch(read_pose(pose_file), read_body_shape(shape_file)), PEER_NAMES


def _as_named(points, names: Sequence[str]) -> Mapping[str, np.ndarray]:
    if isinstance(points, Mapping):
        return {k: np.asarray(v, float) for k, v in points.items()}
    arr = np.asarray(points, float)
    require(arr.ndim >= 2 and arr.shape[-2:] == (len(names), 3),
            f"points must have shape (..., {len(names)}, 3) to match their names, got {arr.shape}")
    return {n: arr[..., i, :] for i, n in enumerate(names)}


def mean_joint_distance(ours, theirs, *, joints: Sequence[str] = SHARED_JOINTS,
                        ours_names: Sequence[str] = OUR_NAMES,
                        theirs_names: Sequence[str] = PEER_NAMES) -> float:
    """Mean Euclidean distance (metres) over the named joints.

    ours, theirs : {name: (..., 3)} dicts, or (..., J, 3) arrays whose joint axis follows
        ``ours_names`` (default: ipf-jax's 19 points) / ``theirs_names`` (default: bodytrack's
        points). Leading axes (e.g. frames) must broadcast; the mean runs over them too.
    """
    a, b = _as_named(ours, ours_names), _as_named(theirs, theirs_names)
    missing = [j for j in joints if j not in a or j not in b]
    require(not missing, f"joints missing from one side: {', '.join(missing)}")
    d = [np.linalg.norm(a[j] - b[j], axis=-1) for j in joints]
    return float(np.mean(np.stack(d)))


class OurFit(NamedTuple):
    """q : (31,) our DOF vector;  height_m : fitted standing height;  rms_m : RMS of the 3D
    joint residuals (metres);  points : (19, 3) our fitted points (world metres)."""

    q: np.ndarray
    height_m: float
    rms_m: float
    points: np.ndarray


def _dofs_moving(names: Sequence[str]) -> np.ndarray:
    """Indices of the DOFs that move at least one of the named points (others stay at 0)."""
    point_frame = {p.name: p.frame for p in POINTS}
    parent = {f.name: f.parent for f in FRAMES}
    frames_used: set[str] = set()
    for n in names:
        f = point_frame[n]
        while f is not None:
            frames_used.add(f)
            f = parent[f]
    moving = set(TRANSLATION_DOFS)
    for f in FRAMES:
        if f.name in frames_used:
            moving |= {DOF_INDEX[d] for _, _, d in f.rotation}
    return np.array(sorted(moving))


def _heading(points: Mapping[str, np.ndarray], up: np.ndarray) -> float:
    """Root yaw that turns our body's left (+y) onto the subject's hip / shoulder axis."""
    left = np.zeros(3)
    for a, b in (("left_hip", "right_hip"), ("left_shoulder", "right_shoulder")):
        if a in points and b in points:
            left += points[a] - points[b]
    local = up.T @ left  # in the up-aligned frame: z is up
    return float(np.arctan2(-local[0], local[1]))


def fit_our_pose(points: Mapping[str, np.ndarray], *, joints: Sequence[str] = SHARED_JOINTS,
                 up: str = "+z", limits: str = "default", height_m: float | None = None) -> OurFit:
    """Fit ipf-jax's 31-DOF body (and its height) to named 3D points.

    Parameters
    ----------
    points : {name: (3,) world metres}, e.g. :func:`~ipf_jax.analysis.bodytrack.bodytrack_points`.
    joints : the names to fit (each must be one of our points and present in ``points``).
    up : the world's up axis (bodytrack: ``+z``).
    limits : DOF limits preset or file; the fit stays inside them (root translation +-1000 m).
    height_m : keep this standing height fixed; by default it is fitted too (1.2..2.2 m), since
        the default shape is a 1.75 m adult and every length scales with height.

    Returns
    -------
    :class:`OurFit`. DOFs that move none of ``joints`` (head, ankles with the default set) are 0.
    """
    missing = [j for j in joints if j not in points or j not in POINT_INDEX]
    require(not missing, f"cannot fit: no such point on one side: {', '.join(missing)}")
    target = np.stack([np.asarray(points[j], float) for j in joints])  # (J, 3)
    require(bool(np.all(np.isfinite(target))), "cannot fit: target points are not finite")
    U = up_rotation(up)
    lim = load_limits(limits)
    base = default_shape()
    idx = np.array([POINT_INDEX[j] for j in joints])
    free = _dofs_moving(joints)
    angles = np.array([i for i in free if DOFS[i].unit == "rad"])
    lower, upper = lim.lower.copy(), lim.upper.copy()
    yaw = DOF_INDEX["root_yaw"]
    lower[yaw], upper[yaw] = -2 * np.pi, 2 * np.pi  # periodic: let it cross +-pi, wrap afterwards

    def unpack(x):
        q = np.zeros(len(DOFS))
        q[free] = x[: len(free)]
        h = height_m if height_m is not None else x[-1]
        return q, h

    def residual(x):
        q, h = unpack(x)
        pts = forward_kinematics(q, base.values * (h / base.height_m), U).points
        return np.concatenate([(pts[idx] - target).ravel(), _PRIOR * q[angles]])

    # start: sacrum above the hip centres, facing along the hip / shoulder axes, limbs slightly bent
    h0 = height_m or 1.75
    hips = [points[n] for n in ("left_hip", "right_hip") if n in points]
    centre = np.mean(hips, axis=0) if hips else target.mean(axis=0)
    q0 = np.zeros(len(DOFS))
    q0[:3] = centre + U[:, 2] * base["hip_down"] * h0 / base.height_m
    q0[yaw] = _heading(points, U)
    for name in ("left_knee_flexion", "right_knee_flexion", "left_elbow_flexion",
                 "right_elbow_flexion"):
        q0[DOF_INDEX[name]] = 0.2
    q0 = np.clip(q0, lower, upper)
    x0, lo, hi = q0[free], lower[free], upper[free]
    if height_m is None:
        x0, lo, hi = np.append(x0, h0), np.append(lo, _HEIGHT_RANGE[0]), np.append(hi, _HEIGHT_RANGE[1])
    sol = least_squares(residual, x0, bounds=(lo, hi), x_scale="jac")
    q, h = unpack(sol.x)
    q[yaw] = (q[yaw] + np.pi) % (2 * np.pi) - np.pi
    pts = forward_kinematics(q, base.values * (h / base.height_m), U).points
    rms = float(np.sqrt(np.mean(np.sum((pts[idx] - target) ** 2, axis=-1))))
    return OurFit(q, float(h), rms, pts)
