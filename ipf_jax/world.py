"""The world frame: which signed axis is up, and the rotation that stands the body up in it.

Calibrations put their world axes anywhere: bodytrack has +Z up, the Utrecht cameras -Z up, many
lab systems +Y up. The up axis is detected from the cameras (they sit above the floor and look
down or level, with their image 'up' roughly along world up) or given (``--up``), and recorded in
every output. The floor is the plane ``up . X = 0`` (calibration origin on the floor).
"""
from __future__ import annotations

import numpy as np

from .camera import Camera
from .errors import IPFError

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


def up_scores(cameras: list[Camera]) -> dict[str, float]:
    """Evidence for each signed axis being up (larger is better)."""
    scores = {}
    for axis in AXES:
        a = axis_vector(axis)
        s = 0.0
        for cam in cameras:
            c = cam.centre
            height = float(a @ c) / max(np.linalg.norm(c), 1e-9)  # camera above the floor
            looks_down = -float(a @ cam.view_dir)  # optical axis points down or level
            image_up = float(a @ (cam.R.T @ np.array([0.0, -1.0, 0.0])))  # image up ~ world up
            s += 1.0 * height + 1.0 * looks_down + 0.5 * image_up
        scores[axis] = s / len(cameras)
    return scores


def detect_up_axis(cameras: list[Camera]) -> str:
    """The signed world axis that is most likely up."""
    scores = up_scores(cameras)
    return max(scores, key=scores.get)
