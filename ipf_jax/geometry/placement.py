"""Placing a person, and a camera, from ONE camera's silhouette (docs/single_camera.md).

A level camera (optical axis nearly horizontal) sees the body's centroid along a ray nearly
parallel to the floor, so intersecting that ray with a plane at the centroid's height is
ill-conditioned (a pixel moves the person by several centimetres at 10 m). A standing person gives
two better cues: the lowest silhouette pixel (the soles, on the floor) and the highest (the top of
the head, ``height_m`` above it). With ``t_f`` the tangent of the feet ray's depression below the
horizon and ``t_h`` that of the head ray's elevation, a person of height H stands at horizontal
distance ``D = H / (t_f + t_h)`` from the camera, whose centre is ``D t_f`` above the floor. That
needs the camera's orientation and intrinsics only; the nominal camera's height is not used.

Depth (distance along the view) is what one camera measures worst: :func:`steady_depth` moves a
tracked body along its viewing rays to a depth that changes linearly over time.
"""
from __future__ import annotations

import cv2
import numpy as np

from ..body.model import POINT_INDEX
from ..errors import require
from .camera import Camera, validate_camera
from .rays import viewing_ray


def person_extent(mask: np.ndarray, min_area: int = 50):
    """Feet and head pixels (u, v) of the person in a (H, W) bool mask, or None.

    The person is the largest 8-connected blob plus the blobs of at least a tenth of its area
    that overlap its columns (a silhouette cut across by clothes the colour of the background
    falls apart into a torso and legs). The feet point is the bottom edge of the lowest row, the
    head point the top edge of the highest row, both at the person's mean column (the vertical
    through the body's centre, not through a foot that may be a stride ahead).
    Returns ((u_f, v_f), (u_h, v_h)).
    """
    n, _, stats, cents = cv2.connectedComponentsWithStats(np.asarray(mask, np.uint8), connectivity=8)
    if n <= 1:
        return None
    area = stats[1:, cv2.CC_STAT_AREA]
    k = int(np.argmax(area))
    if area[k] < min_area:
        return None
    left, width = stats[1:, cv2.CC_STAT_LEFT], stats[1:, cv2.CC_STAT_WIDTH]
    overlap = (left < left[k] + width[k]) & (left + width > left[k]) & (area >= 0.1 * area[k])
    keep = 1 + np.nonzero(overlap)[0]
    top = int(stats[keep, cv2.CC_STAT_TOP].min())
    bottom = int((stats[keep, cv2.CC_STAT_TOP] + stats[keep, cv2.CC_STAT_HEIGHT]).max()) - 1
    u = float(np.sum(cents[keep, 0] * stats[keep, cv2.CC_STAT_AREA]) /
              np.sum(stats[keep, cv2.CC_STAT_AREA]))
    return (u, bottom + 0.5), (u, top - 0.5)


def _tan_elevation(d: np.ndarray, up: np.ndarray) -> float:
    e = float(up @ d)
    return e / max(np.sqrt(max(1.0 - e * e, 0.0)), 1e-9)


def stand_distance(cam: Camera, feet_uv, head_uv, up: np.ndarray,
                   height_m: float) -> tuple[float, float]:
    """Horizontal distance (m) of a person of ``height_m`` from the camera, and the camera height
    above the floor that makes the feet touch it (see module doc). Returns (nan, nan) when the
    head is not above the feet."""
    _, d_f = viewing_ray(cam, *feet_uv)
    _, d_h = viewing_ray(cam, *head_uv)
    t_f, t_h = -_tan_elevation(d_f, up), _tan_elevation(d_h, up)
    if not t_f + t_h > 1e-6:
        return np.nan, np.nan
    distance = height_m / (t_f + t_h)
    return distance, distance * t_f


def floor_point_single(mask: np.ndarray, cam: Camera, up: np.ndarray,
                       height_m: float | None = None) -> np.ndarray | None:
    """(3,) floor point under a person seen by ONE camera, or None (no blob, ray misses the floor).

    With ``height_m``: at the distance where a person that tall spans the silhouette's height
    (independent of the camera's height, right for a level camera). Without: where the ray through
    the lowest silhouette pixel meets the floor ``up . X = 0``.
    """
    ext = person_extent(mask)
    if ext is None:
        return None
    feet, head = ext
    centre, d_f = viewing_ray(cam, *feet)
    if height_m is not None:
        distance, _ = stand_distance(cam, feet, head, up, height_m)
        horiz = d_f - up * (up @ d_f)
        if not np.isfinite(distance) or np.linalg.norm(horiz) < 1e-9:
            return None
        p = centre + distance * horiz / np.linalg.norm(horiz)
    else:
        denom = float(up @ d_f)
        if denom > -1e-6:  # the feet ray does not go down
            return None
        p = centre - d_f * float(up @ centre) / denom
    return p - up * float(up @ p)


def camera_height_from_person(cam: Camera, masks: list[np.ndarray], up: np.ndarray, height_m: float,
                              *, where: str = "") -> tuple[float, np.ndarray]:
    """Camera centre height above the floor from silhouettes of a standing/walking person.

    masks : K (H, W) bool masks at the camera's resolution.
    Returns (median height in metres, (K,) per-mask estimates with nan where no person was seen).
    The median is robust to a few frames with shadows or a cut-off head. A walking person's
    silhouette is a little shorter than the standing height (knees, head bob), which biases the
    estimate low by about the same fraction (1-2 %).
    """
    est = np.full(len(masks), np.nan)
    for i, m in enumerate(masks):
        ext = person_extent(m)
        if ext is not None:
            est[i] = stand_distance(cam, ext[0], ext[1], up, height_m)[1]
    good = est[np.isfinite(est) & (est > 0)]
    require(len(good) > 0, "camera_height \"from_person\": no person silhouette in the sampled "
            "frames (check 'frames', 'roi' and the segmentation)", where or None)
    return float(np.median(good)), est


#: :func:`height_from_view`: the percentile of the per-frame estimates taken as the standing
#: height (a walker's head is at its highest near mid-stance, a few frames of a stride)
HEIGHT_PERCENTILE = 90
#: fewest frames with a usable silhouette for :func:`height_from_view` to give an answer
HEIGHT_MIN_FRAMES = 5
#: steepest feet ray used (tangent of its depression: 1.0 = 45 deg below the horizon): from above,
#: the highest silhouette pixel is no longer the top of the head
HEIGHT_STEEPEST = 1.0
#: the camera's image rows must be within about 25 deg of level (sine; either way up): a camera
#: rolled on its side sees the body's width between its silhouette's top and bottom rows
HEIGHT_ROLL = 0.42


def height_from_view(cam: Camera, masks: list[np.ndarray], up: np.ndarray) -> tuple[float, np.ndarray]:
    """A person's standing height (m) from ONE calibrated camera, and the (K,) per-mask estimates
    (nan where a mask was not usable).

    Single-view metrology on a flat floor (the plane ``up . X = 0``): the silhouette's lowest
    point is on the floor, so the feet ray's depression (tangent ``t_f``) and the camera centre's
    height ``c`` give the person's horizontal distance ``c / t_f``; the highest point's elevation
    (tangent ``t_h``) then gives the height ``c (t_f + t_h) / t_f``. "Lowest" and "highest" are
    read in the world (the two ends' rays' elevations), so a camera mounted upside down works too;
    nan for a camera rolled on its side (:data:`HEIGHT_ROLL`).
    A mask is skipped when its person touches the image's border (cut off), when the feet ray is
    steeper than :data:`HEIGHT_STEEPEST` or does not go down. The answer is the
    :data:`HEIGHT_PERCENTILE` th percentile (a walker's head bobs by 2-4 cm; the highest frames
    are the upright ones), nan with fewer than :data:`HEIGHT_MIN_FRAMES` usable masks or a camera
    at or below the floor. It needs the camera's height to be right, unlike :func:`stand_distance`.
    """
    est = np.full(len(masks), np.nan)
    c = float(up @ cam.centre)
    if not c > 0 or abs(float(up @ (cam.R.T @ np.array([1.0, 0.0, 0.0])))) > HEIGHT_ROLL:
        return np.nan, est
    for i, m in enumerate(masks):
        m = np.asarray(m, bool)
        ext = person_extent(m)
        if ext is None:
            continue
        rows = np.flatnonzero(m.any(1))
        cols = np.flatnonzero(m.any(0))
        if rows[0] == 0 or rows[-1] == m.shape[0] - 1 or cols[0] == 0 or cols[-1] == m.shape[1] - 1:
            continue  # cut off by the image's border
        e = [_tan_elevation(viewing_ray(cam, *uv)[1], up) for uv in ext]
        t_f, t_h = -min(e), max(e)
        if 1e-3 < t_f <= HEIGHT_STEEPEST:
            est[i] = c * (t_f + t_h) / t_f
    good = est[np.isfinite(est)]
    if len(good) < HEIGHT_MIN_FRAMES:
        return np.nan, est
    return float(np.percentile(good, HEIGHT_PERCENTILE)), est


def camera_at_height(cam: Camera, up: np.ndarray, height: float) -> Camera:
    """The same camera (orientation, intrinsics) moved along ``up`` to ``height`` m above the floor."""
    c = cam.centre
    c = c + up * (height - float(up @ c))
    moved = Camera(K=cam.K, dist=cam.dist, R=cam.R, T=-cam.R @ c, width=cam.width,
                   height=cam.height, name=cam.name, source=cam.source)
    return validate_camera(moved)



def steady_depth(joints: np.ndarray, cam: Camera, up: np.ndarray,
                 frames: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Translations that put each frame's body at a steady depth from ONE camera.

    Depth (distance along the camera's horizontal optical axis) is what one camera measures
    worst, and a tracker's frame-to-frame depth jitter looks like sideways steps and turns. Each
    frame's body is moved along its sacrum's viewing ray (the sacrum's image and the body's shape
    are kept) so that the sacrum's depth follows the straight line fitted to it over time (a
    straight walk at any angle to the view).

    joints : (T, J, 3) metres (nan rows = missing). frames : (T,) frame numbers (default 0..T-1).
    Returns ((T, 3) shifts, 0 on missing rows; (2,) fitted depth at the mean frame and its slope
    per frame).
    """
    joints = np.asarray(joints, float)
    frames = np.arange(len(joints)) if frames is None else np.asarray(frames, float)
    c = cam.centre
    axis = cam.view_dir - up * (up @ cam.view_dir)
    require(np.linalg.norm(axis) > 0.1, "steady depth needs a camera that does not look straight "
            "down or up")
    axis /= np.linalg.norm(axis)
    sacrum = joints[:, POINT_INDEX["sacrum"]]
    ok = np.all(np.isfinite(sacrum), axis=1)
    require(ok.sum() >= 2, "fewer than two tracked frames")
    depth = (sacrum[ok] - c) @ axis
    design = np.stack([np.ones(ok.sum()), frames[ok] - frames[ok].mean()], axis=1)
    fit = np.linalg.lstsq(design, depth, rcond=None)[0]
    shifts = np.zeros_like(sacrum)
    ray = sacrum[ok] - c
    target = fit[0] + fit[1] * (frames[ok] - frames[ok].mean())
    shifts[ok] = ray * (target / (ray @ axis))[:, None] - ray
    return shifts, fit
