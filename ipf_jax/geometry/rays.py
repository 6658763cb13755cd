"""Viewing rays from silhouettes: a blob's centroid back-projected, rays intersected or cut by a plane.

Each camera's largest 8-connected foreground blob gives a ray from the camera centre through its
centroid (distortion removed). Several rays meet, in the least-squares sense, near the body's
centre; one ray meets a horizontal plane at a given height. The tracker's body origin positioning
(:mod:`ipf_jax.tracking.origin`) and the automatic initialisation (:mod:`ipf_jax.tracking.initialise`)
place the person with them; single-view placement (:mod:`ipf_jax.geometry.placement`) uses
:func:`viewing_ray`.
"""
from __future__ import annotations

import cv2
import numpy as np

from .camera import Camera


def blobs(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(stats (K, 5), centroids (K, 2)) of the 8-connected foreground blobs of ``mask`` (nonzero
    as uint8), row 0 the background: ``cv2.connectedComponentsWithStats``'s, computed once for
    every user of a frame's masks."""
    _, _, stats, cents = cv2.connectedComponentsWithStats(mask.astype(np.uint8), connectivity=8)
    return stats, cents


def blob_centroid(mask: np.ndarray, min_area: int = 20,
                  found: tuple[np.ndarray, np.ndarray] | None = None) -> tuple[float, float] | None:
    """Centroid (u, v) of the largest 8-connected foreground blob, or None; ``found``: the
    mask's :func:`blobs` when the caller has them."""
    stats, cents = blobs(mask) if found is None else found
    n = len(stats)
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


def camera_rays(masks: list[np.ndarray], cameras: list[Camera], found: list | None = None) -> list:
    """Per camera, the ray through its largest blob's centroid, or None when it sees no one;
    ``found``: per mask its :func:`blobs` (or None) when the caller has them."""
    out = []
    for mask, cam, f in zip(masks, cameras, found or [None] * len(masks)):
        c = blob_centroid(mask, found=f)
        out.append(None if c is None else viewing_ray(cam, *c))
    return out


def silhouette_rays(masks: list[np.ndarray], cameras: list[Camera]) -> list[tuple[np.ndarray, np.ndarray]]:
    """The rays of the cameras that see someone."""
    return [r for r in camera_rays(masks, cameras) if r is not None]


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


def is_upright(cam: Camera, up: np.ndarray, cos_limit: float = 0.95) -> bool:
    """True when the camera's image 'up' is within ~18 deg of the world's (a level, unrolled
    camera: people stand upright in its images, feet at the bottom)."""
    return float(up @ (cam.R.T @ np.array([0.0, -1.0, 0.0]))) > cos_limit
