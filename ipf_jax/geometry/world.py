"""The world frame: which signed axis is up, and the rotation that stands the body up in it.

Calibrations put their world axes anywhere: bodytrack has +Z up, the Utrecht cameras -Z up, many
lab systems +Y up. The up axis is given (``--up``) or detected, and recorded in every output. The
floor is the plane ``up . X = 0`` (calibration origin on the floor, as checkerboard calibrations
make it). Detection:

* **which axis**: with three or more cameras spread around a room, their centres lie near a
  horizontal plane, so the axis closest to that plane's normal is vertical. With one or two
  cameras (or cameras not spread out) people are: the long axis of each silhouette points at the
  image of the vertical through the person, i.e. along the line to the up axis's vanishing point.
  Without masks the cameras' image 'up' direction is the last resort (right for level cameras,
  wrong for ceiling cameras mounted upside down) - pass ``--up`` then.
* **which sign**: the cameras are above the floor.
"""
from __future__ import annotations

import cv2
import numpy as np

from ..errors import IPFError
from .camera import Camera

AXES = ("+x", "-x", "+y", "-y", "+z", "-z")


def axis_vector(axis: str) -> np.ndarray:
    if axis not in AXES:
        raise IPFError(f"unknown up axis {axis!r} (choose one of {', '.join(AXES)})")
    v = np.zeros(3)
    v["xyz".index(axis[1])] = 1.0 if axis[0] == "+" else -1.0
    return v


def up_rotation(axis: str) -> np.ndarray:
    """(3, 3) proper rotation U with U @ (0, 0, 1) = the world up vector."""
    up = axis_vector(axis)
    # any horizontal world axis for the body's x (heading is searched over 360 degrees anyway)
    i = int(np.argmax(np.abs(up)))
    fwd = np.zeros(3)
    fwd[(i + 1) % 3] = 1.0
    left = np.cross(up, fwd)
    return np.stack([fwd, left, up], axis=1)


def _plane_axis_scores(cameras: list[Camera]) -> np.ndarray | None:
    """|normal . axis| for x, y, z when the camera centres span a clear plane, else None."""
    if len(cameras) < 3:
        return None
    c = np.array([cam.centre for cam in cameras])
    _, s, vt = np.linalg.svd(c - c.mean(0))
    if s[1] < 1e-6 or s[2] / s[1] > 0.25:  # collinear, or no dominant plane
        return None
    return np.abs(vt[2])


def _silhouette_axis_scores(cameras: list[Camera], masks: list[np.ndarray]) -> np.ndarray | None:
    """How well each world axis's image direction matches the silhouettes' long axes (x, y, z)."""
    total = np.zeros(3)
    used = 0
    for cam, mask in zip(cameras, masks):
        m = cv2.moments(mask.astype(np.uint8), binaryImage=True)
        if m["m00"] < 50:
            continue
        cu, cv_ = m["m10"] / m["m00"], m["m01"] / m["m00"]
        cov = np.array([[m["mu20"], m["mu11"]], [m["mu11"], m["mu02"]]]) / m["m00"]
        evals, evecs = np.linalg.eigh(cov)
        if evals[1] < 1.5 * max(evals[0], 1e-9):  # not elongated: no cue
            continue
        long_axis = evecs[:, 1]
        for k in range(3):
            vp = cam.K @ cam.R[:, k]  # vanishing point of world axis k (homogeneous)
            if abs(vp[2]) > 1e-9 * np.linalg.norm(vp):
                d = vp[:2] / vp[2] - np.array([cu, cv_])
                d = d * np.sign(vp[2])
            else:
                d = vp[:2]
            n = np.linalg.norm(d)
            if n > 0:
                total[k] += abs(d @ long_axis) / n
        used += 1
    return total / used if used else None


def _image_up_scores(cameras: list[Camera]) -> np.ndarray:
    return np.abs(np.mean([cam.R.T @ np.array([0.0, -1.0, 0.0]) for cam in cameras], axis=0))


def detect_up_axis(cameras: list[Camera], masks: list[np.ndarray] | None = None) -> str:
    """The signed world axis that is up (see module doc). ``masks``: one frame, full resolution."""
    axis_scores = _plane_axis_scores(cameras)
    if axis_scores is None and masks is not None:
        axis_scores = _silhouette_axis_scores(cameras, masks)
    if axis_scores is None:
        axis_scores = _image_up_scores(cameras)
    k = int(np.argmax(axis_scores))
    heights = np.array([cam.centre[k] for cam in cameras])
    sign = "+" if np.sum(heights) >= 0 else "-"
    return f"{sign}{'xyz'[k]}"
