"""bodytrack's image side: cone outlines as it projects them, foreground checks, Result%04d.bmp.

bodytrack projects each cone as a quadrilateral: the two end discs' diameters that are
perpendicular to the line of sight from the camera centre to the cone's middle. Its Result overlay
draws those quadrilaterals at half size into a 2 x 2 mosaic (camera k at column k % 2, row k // 2)
with Bresenham lines, coloured by body side. Re-drawing them here the same way lets a test compare
our kinematics with bodytrack's own drawing pixel by pixel.
"""
from __future__ import annotations

from typing import NamedTuple, Sequence

import numpy as np

from ...errors import require
from ...geometry.camera import Camera
from ...geometry.host import project_points
from .io import NUM_PARTS, read_bmp
from .kinematics import BodytrackParts

#: Overlay colour class of each part (bodytrack's OutputBMP): 1 cyan = left limbs, 2 yellow =
#: right limbs, 3 magenta = torso and head.
PART_COLOUR = np.array([3, 1, 1, 2, 2, 1, 1, 2, 2, 3], np.int8)
COLOURS_RGB = {1: (0, 255, 255), 2: (255, 255, 0), 3: (255, 0, 255)}


def cone_outlines(parts: BodytrackParts, cam: Camera) -> np.ndarray:
    """Project each cone as bodytrack does.

    Returns
    -------
    corners : (10, 4, 2) pixel coordinates: bottom-left, top-left, top-right, bottom-right side
        points, where "left/right" is the side perpendicular to the view of that camera.
    """
    eye = cam.centre  # world metres
    corners = np.empty((NUM_PARTS, 4, 2))
    for i in range(NUM_PARTS):
        # the cone's frame with its elliptic cross-section folded in, as bodytrack's pose matrix
        M = parts.frames[i].copy()
        M[:3, 0] *= parts.scale[i, 0]
        M[:3, 1] *= parts.scale[i, 1]
        length = parts.length[i]
        r = np.array([0.0, 0.0, length / 2]) - (np.linalg.inv(M) @ np.append(eye, 1.0))[:3]
        side = np.array([-r[1], r[0], 0.0]) / np.hypot(r[0], r[1])
        bottom, top = parts.radii[i]
        local = np.array([-bottom * side, -top * side + [0, 0, length],
                          top * side + [0, 0, length], bottom * side])  # (4, 3)
        world = local @ M[:3, :3].T + M[:3, 3]
        corners[i] = project_points(cam, world)[0]
    return corners


def axis_samples(parts: BodytrackParts, num: int = 9) -> np.ndarray:
    """(10, num, 3) world points evenly spaced along each cone's axis, ends included."""
    require(num >= 2, "need at least 2 samples per axis")
    t = np.linspace(0.0, 1.0, num)[None, :, None]
    return parts.a[:, None, :] * (1 - t) + parts.b[:, None, :] * t


def fg_hits(points: np.ndarray, cam: Camera, mask: np.ndarray) -> np.ndarray:
    """points : (..., 3) world metres; mask : (H, W) bool -> (...,) bool, True on foreground.

    Sampled like bodytrack at ``int(u + 0.5), int(v + 0.5)``; points off the image count as misses.
    """
    uv = project_points(cam, points)[0]
    ij = np.floor(uv + 0.5).astype(int)
    h, w = mask.shape
    inside = (ij[..., 0] >= 0) & (ij[..., 0] < w) & (ij[..., 1] >= 0) & (ij[..., 1] < h)
    hit = np.zeros(inside.shape, bool)
    hit[inside] = mask[ij[..., 1][inside], ij[..., 0][inside]]
    return hit


def fg_fraction(parts: BodytrackParts, cameras: Sequence[Camera], masks: Sequence[np.ndarray],
                num: int = 9) -> float:
    """Fraction of the cones' axis samples (all parts, all cameras) that fall on foreground."""
    samples = axis_samples(parts, num)
    return float(np.mean([fg_hits(samples, c, m) for c, m in zip(cameras, masks)]))


def _bresenham(x1: int, y1: int, x2: int, y2: int) -> list[tuple[int, int]]:
    # the same walk as FlexLine, so the drawn pixels coincide with bodytrack's exactly; its steep
    # branch is the shallow one with x and y exchanged
    steep = abs(y2 - y1) > abs(x2 - x1)
    if steep:
        x1, y1, x2, y2 = y1, x1, y2, x2
    dx, incx = abs(x2 - x1), (1 if x2 >= x1 else -1)
    dy, incy = abs(y2 - y1), (1 if y2 >= y1 else -1)
    x, y, out = x1, y1, []
    balance = 2 * dy - dx
    while x != x2:
        out.append((x, y))
        if balance >= 0:
            y += incy
            balance -= 2 * dx
        balance += 2 * dy
        x += incx
    out.append((x, y))
    return [(b, a) for a, b in out] if steep else out


def draw_outlines(corners: np.ndarray, labels: np.ndarray, origin: tuple[int, int],
                  size: tuple[int, int]) -> None:
    """Draw one camera's (10, 4, 2) full-size corners at half size into ``labels`` in place.

    labels : (H, W) int8 canvas (the whole mosaic); origin : (x, y) of the view's top-left corner;
    size : (w, h) of the view. Parts are drawn in order, later ones over earlier ones, with
    bodytrack's integer rounding (truncate, then halve) and its end-point test. bodytrack writes
    past a view's edge into the neighbouring view; pixels off the whole mosaic are dropped here.
    """
    ox, oy = origin
    w, h = size
    H, W = labels.shape
    t = np.trunc(corners).astype(int)
    half = np.sign(t) * (np.abs(t) // 2)  # C's (int)x / 2: both steps truncate toward zero
    for i in range(len(corners)):
        for k in range(4):
            (x1, y1), (x2, y2) = half[i, k], half[i, (k + 1) % 4]
            if x2 > w or y2 > h:
                continue  # FlexLine's guard
            for x, y in _bresenham(int(x1), int(y1), int(x2), int(y2)):
                if 0 <= ox + x < W and 0 <= oy + y < H:
                    labels[oy + y, ox + x] = PART_COLOUR[i]


def render_overlay(corners: np.ndarray, width: int = 640, height: int = 480) -> np.ndarray:
    """corners : (C, 10, 4, 2), C <= 4 cameras -> (height, width) int8 label mosaic (0 = none)."""
    labels = np.zeros((height, width), np.int8)
    w, h = width // 2, height // 2
    for k, c in enumerate(corners):
        draw_outlines(c, labels, ((k % 2) * w, (k // 2) * h), (w, h))
    return labels


def read_overlay(path) -> np.ndarray:
    """Result%04d.bmp -> (H, W) int8 labels: the colour class of every drawn pixel, 0 elsewhere.

    The background is a grey image (R = G = B); bodytrack draws in pure cyan, yellow, magenta.
    """
    rgb = read_bmp(path, colour=True).astype(int)
    labels = np.zeros(rgb.shape[:2], np.int8)
    for cls, colour in COLOURS_RGB.items():
        labels[np.all(rgb == colour, axis=-1)] = cls
    grey = (rgb[..., 0] == rgb[..., 1]) & (rgb[..., 1] == rgb[..., 2])
    require(bool(np.all(grey | (labels > 0))), "overlay has colours other than bodytrack's three", path)
    return labels


class Agreement(NamedTuple):
    """How well two label images agree.

    exact : fraction of drawn pixels (either image) drawn in both with the same class (IoU).
    ours_near : fraction of our drawn pixels within ``tol`` px of a same-class pixel of theirs.
    theirs_near : the converse.
    """

    exact: float
    ours_near: float
    theirs_near: float


def _dilate(mask: np.ndarray, tol: int) -> np.ndarray:
    out = mask.copy()
    h, w = mask.shape
    for dy in range(-tol, tol + 1):
        for dx in range(-tol, tol + 1):
            out[max(dy, 0):h + min(dy, 0), max(dx, 0):w + min(dx, 0)] |= \
                mask[max(-dy, 0):h + min(-dy, 0), max(-dx, 0):w + min(-dx, 0)]
    return out


def agreement(ours: np.ndarray, theirs: np.ndarray, tol: int = 1) -> Agreement:
    """Compare two (H, W) label images (same class must match); see :class:`Agreement`."""
    require(ours.shape == theirs.shape, "label images differ in size")
    both = (ours > 0) & (ours == theirs)
    either = (ours > 0) | (theirs > 0)
    near_o = near_t = 0
    for cls in COLOURS_RGB:
        o, t = ours == cls, theirs == cls
        near_o += int(np.sum(o & _dilate(t, tol)))
        near_t += int(np.sum(t & _dilate(o, tol)))
    n_o, n_t = int(np.sum(ours > 0)), int(np.sum(theirs > 0))
    return Agreement(float(both.sum() / max(either.sum(), 1)), near_o / max(n_o, 1),
                     near_t / max(n_t, 1))
