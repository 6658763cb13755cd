"""Body origin positioning from the silhouettes (the paper's 'body origin positioning algorithm').

Each camera's largest silhouette blob gives a viewing ray through its centroid. With two or more
cameras the rays are intersected (least squares) into a 3D *anchor* near the body's centre; with
one camera the ray meets a horizontal plane at a given height. The anchor is an observation of the
current frame, not a prediction: the tracker shifts every particle's root by the anchor's
displacement since the previous frame, so the filter's noise only has to cover what the
displacement does not explain (limb motion moves the centroid a little). No motion model is used.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..geometry.camera import Camera
from ..geometry.rays import camera_rays, intersect_rays, is_upright, ray_at_height

MAX_SHIFT_M = 0.5  # a larger jump between frames is not trusted (a second person, clutter)


class FrameAnchor(NamedTuple):
    """What a frame's silhouettes say about where the person is.

    rays : per camera, the ray through its largest blob's centroid, or None.
    feet : (3,) floor point under the person from a single upright camera (its lowest and highest
    silhouette pixels and the body height, see :mod:`ipf_jax.geometry.placement`), or None.
    """

    rays: list
    feet: np.ndarray | None

    def to_json(self) -> dict:
        return {"rays": [None if r is None else [r[0].tolist(), r[1].tolist()] for r in self.rays],
                "feet": None if self.feet is None else self.feet.tolist()}

    @staticmethod
    def from_json(doc: dict | None) -> "FrameAnchor | None":
        if not doc:
            return None
        rays = [None if r is None else (np.asarray(r[0]), np.asarray(r[1])) for r in doc["rays"]]
        return FrameAnchor(rays, None if doc["feet"] is None else np.asarray(doc["feet"]))


def observe_anchor(masks: list[np.ndarray], cameras: list[Camera], up: np.ndarray,
                   height_m: float, rays: list | None = None) -> FrameAnchor:
    """The frame's anchor evidence (masks and cameras at the same resolution); ``rays``: their
    :func:`~ipf_jax.geometry.rays.camera_rays` when the caller has them already."""
    rays = camera_rays(masks, cameras) if rays is None else rays
    seen = [k for k, r in enumerate(rays) if r is not None]
    feet = None
    if len(seen) == 1 and is_upright(cameras[seen[0]], up):
        from ..geometry.placement import floor_point_single

        feet = floor_point_single(masks[seen[0]], cameras[seen[0]], up, height_m)
    return FrameAnchor(rays, feet)


def anchor_point(rays, up: np.ndarray, height: float) -> np.ndarray | None:
    """The 3D anchor of a frame's silhouette rays (see module doc); ``height`` for one camera."""
    p = intersect_rays(rays)
    if p is None and len(rays) == 1:
        p = ray_at_height(rays[0], up, height)
    return p


def root_shift(previous: FrameAnchor | None, current: FrameAnchor, up: np.ndarray,
               height: float) -> np.ndarray:
    """Displacement of the anchor between two frames, zero when it cannot be measured.

    Several cameras seeing someone in both frames: their triangulated centroids. One upright
    camera: its floor points. One other camera: its centroid rays on the same horizontal plane at
    ``height`` (so the displacement does not depend on how well that height fits the body).
    """
    if previous is None:
        return np.zeros(3)
    both = [k for k, (p, c) in enumerate(zip(previous.rays, current.rays)) if p is not None and c is not None]
    if len(both) == 1 and previous.feet is not None and current.feet is not None:
        d = current.feet - previous.feet
    elif both:
        a = anchor_point([previous.rays[k] for k in both], up, height)
        b = anchor_point([current.rays[k] for k in both], up, height)
        if a is None or b is None:
            return np.zeros(3)
        d = b - a
    else:
        return np.zeros(3)
    return d if np.linalg.norm(d) <= MAX_SHIFT_M else np.zeros(3)
