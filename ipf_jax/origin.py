"""Body origin positioning from the silhouettes (the paper's 'body origin positioning algorithm').

Each camera's largest silhouette blob gives a viewing ray through its centroid. With two or more
cameras the rays are intersected (least squares) into a 3D *anchor* near the body's centre; with
one camera the ray meets a horizontal plane at a given height. The anchor is an observation of the
current frame, not a prediction: the tracker shifts every particle's root by the anchor's
displacement since the previous frame, so the filter's noise only has to cover what the
displacement does not explain (limb motion moves the centroid a little). No motion model is used.
"""
from __future__ import annotations

import cv2
import numpy as np

from .camera import Camera

MAX_SHIFT_M = 0.5  # a larger jump between frames is not trusted (a second person, clutter)


def blob_centroid(mask: np.ndarray, min_area: int = 20) -> tuple[float, float] | None:
    """Centroid (u, v) of the largest 8-connected foreground blob, or None."""
    n, _, stats, cents = cv2.connectedComponentsWithStats(mask.astype(np.uint8), connectivity=8)
    if n <= 1:
        return None
    k = 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
    if stats[k, cv2.CC_STAT_AREA] < min_area:
        return None
    return float(cents[k, 0]), float(cents[k, 1])


def viewing_ray(cam: Camera, u: float, v: float) -> tuple[np.ndarray, np.ndarray]:
    """World ray (origin, unit direction) through pixel (u, v), distortion removed."""
    xy = cv2.undistortPoints(np.array([[[u, v]]], np.float64), cam.K, cam.dist).reshape(2)
    d = cam.R.T @ np.array([xy[0], xy[1], 1.0])
    return cam.centre, d / np.linalg.norm(d)


def silhouette_rays(masks: list[np.ndarray], cameras: list[Camera]) -> list[tuple[np.ndarray, np.ndarray]]:
    rays = []
    for mask, cam in zip(masks, cameras):
        c = blob_centroid(mask)
        if c is not None:
            rays.append(viewing_ray(cam, *c))
    return rays


def intersect_rays(rays) -> np.ndarray | None:
    """Least-squares closest point to two or more rays, None when they are (nearly) parallel."""
    if len(rays) < 2:
        return None
    A = sum(np.eye(3) - np.outer(d, d) for _, d in rays)
    b = sum((np.eye(3) - np.outer(d, d)) @ o for o, d in rays)
    if np.linalg.cond(A) > 1e6:
        return None
    return np.linalg.solve(A, b)


def ray_at_height(ray, up: np.ndarray, height: float) -> np.ndarray | None:
    """Where a ray meets the plane ``up . X = height`` (in front of the camera), else None."""
    o, d = ray
    denom = up @ d
    if abs(denom) < 1e-3:
        return None
    t = (height - up @ o) / denom
    return o + t * d if t > 0 else None


def anchor(masks: list[np.ndarray], cameras: list[Camera], up: np.ndarray,
           height: float) -> np.ndarray | None:
    """The frame's 3D anchor (see module doc); ``height`` is used with a single camera only."""
    rays = silhouette_rays(masks, cameras)
    p = intersect_rays(rays)
    if p is None and len(rays) == 1:
        p = ray_at_height(rays[0], up, height)
    return p


def root_shift(previous: np.ndarray | None, current: np.ndarray | None) -> np.ndarray:
    """Displacement to apply to the particles' roots (zero when either anchor is unknown)."""
    if previous is None or current is None:
        return np.zeros(3)
    d = current - previous
    return d if np.linalg.norm(d) <= MAX_SHIFT_M else np.zeros(3)
