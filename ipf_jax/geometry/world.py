"""The world frame: which signed axis is up, and the rotation that stands the body up in it.

Calibrations put their world axes anywhere: bodytrack has +Z up, the Utrecht cameras -Z up, many
lab systems +Y up. The up axis is given (``--up``) or detected, and recorded in every output. The
floor is the plane ``up . X = 0`` (calibration origin on the floor, as checkerboard calibrations
make it). Detection:

* **which axis**: with three or more cameras spread around a room, their centres lie near a
  horizontal plane, so the axis closest to that plane's normal is vertical. With one or two
  cameras (or cameras not spread out) each camera's own orientation says it: a camera level or
  tilted down (or mounted upside down, as ceiling cameras often are) has the vertical close to
  its image's vertical direction, so the world axis that direction is clearly closest to is up.
  A camera tilted about 45 degrees, or cameras that disagree, cannot decide: :class:`IPFError`
  asking for ``--up``. (A camera looking straight down is taken for a level one: give ``--up``
  for a single ceiling camera pointing at the floor.) None of this
  needs the person standing. Given masks of a frame, a silhouette that is long and thin along
  another axis's image direction while hardly along the chosen one (a standing person seen by a
  camera rolled on its side) vetoes the choice with the same error, rather than a silent wrong
  axis; a seated or crouching person is never that clear, so it never vetoes a right choice.
* **which sign**: the cameras are above the floor (or, with camera centres at the floor's
  height, a camera's image 'up' points up).
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


#: a camera decides the vertical when its image's vertical direction is at least this close to one
#: world axis (|cos|) and closer to it than to any other by :data:`AXIS_MARGIN`
AXIS_MIN, AXIS_MARGIN = 0.7, 0.1
VETO_HIGH, VETO_LOW = 0.95, 0.6  # silhouette scores of another axis / of the chosen one


def _camera_axis(cam: Camera) -> int | None:
    """The world axis (0, 1, 2) one camera's orientation makes vertical, or None (see module doc)."""
    vertical = np.sort(np.abs(cam.R[1]))  # the image's vertical direction in world coordinates
    if vertical[2] >= AXIS_MIN and vertical[2] - vertical[1] >= AXIS_MARGIN:
        return int(np.argmax(np.abs(cam.R[1])))
    return None


def _orientation_axis(cameras: list[Camera]) -> int:
    """The vertical world axis all cameras' orientations agree on; IPFError when they cannot."""
    axes = [_camera_axis(c) for c in cameras]
    named = sorted({a for a in axes if a is not None})
    if len(named) != 1:
        problem = ("their orientations disagree" if named else
                   "none is level or tilted down by clearly less than 45 degrees")
        raise IPFError(f"cannot tell which world axis is up from the camera"
                       f"{'s' if len(cameras) > 1 else ''} ({problem}): give it with --up (one of "
                       f"{', '.join(AXES)})")
    return named[0]


def _sign(cameras: list[Camera], k: int) -> str:
    heights = np.array([cam.centre[k] for cam in cameras])
    if abs(heights.mean()) >= 0.1:  # cameras above the floor
        return "+" if heights.sum() >= 0 else "-"
    image_up = np.mean([-cam.R[1, k] for cam in cameras])  # at floor height: level cameras
    return "+" if image_up >= 0 else "-"


def detect_up_axis(cameras: list[Camera], masks: list[np.ndarray] | None = None) -> str:
    """The signed world axis that is up (see module doc). ``masks``: one frame, full resolution,
    used only to veto a camera-orientation choice that a silhouette clearly contradicts."""
    plane = _plane_axis_scores(cameras)
    if plane is not None:
        k = int(np.argmax(plane))
    else:
        k = _orientation_axis(cameras)
        sil = _silhouette_axis_scores(cameras, masks) if masks is not None else None
        if sil is not None and sil[k] <= VETO_LOW and np.delete(sil, k).max() >= VETO_HIGH:
            other = "xyz"[int(np.argmax(np.where(np.arange(3) == k, -1.0, sil)))]
            raise IPFError(f"cannot tell which world axis is up: the camera orientation says "
                           f"{'xyz'[k]}, the silhouettes {other} (a camera rolled on its side?): "
                           f"give it with --up (one of {', '.join(AXES)})")
    return f"{_sign(cameras, k)}{'xyz'[k]}"


def contradicted_up(cameras: list[Camera], masks: list[np.ndarray] | None, up: str) -> str | None:
    """The signed axis the cameras clearly show as up where a given ``up`` says otherwise, or None.

    Only clear evidence counts, so that a rig which fools :func:`detect_up_axis` (the reason to
    give ``--up``) draws no warning: another axis only when the silhouettes' long axes lie along
    it and hardly along the given one (the veto's own levels, :data:`VETO_HIGH` /
    :data:`VETO_LOW`); the other sign of the same axis only when the camera centres stand clearly
    on the other side of the floor (their mean height at least 0.1 world units)."""
    k = int(np.argmax(np.abs(axis_vector(up))))  # (an unknown axis: IPFError)
    sil = _silhouette_axis_scores(cameras, masks) if masks is not None else None
    if sil is not None and sil[k] <= VETO_LOW and np.delete(sil, k).max() >= VETO_HIGH:
        other = int(np.argmax(np.where(np.arange(3) == k, -1.0, sil)))
        return f"{_sign(cameras, other)}{'xyz'[other]}"
    if abs(np.mean([cam.centre[k] for cam in cameras])) >= 0.1 and _sign(cameras, k) != up[0]:
        return f"{_sign(cameras, k)}{'xyz'[k]}"  # (_sign by the cameras' heights, as detection)
    return None
