"""Overlays: the fitted capsules and skeleton drawn over each camera's mask or image.

Colours (BGR): left side red, right side blue, centre green; the mask is grey, the model's filled
raster is tinted, so mismatches (Ns, Nm of the likelihood) are visible at a glance.
"""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from .body.model import BONES, POINT_INDEX, SEGMENT_NAMES
from .body.shape import BodyShape
from .camera import Camera
from .reference.camera import project_points
from .reference.kinematics import forward_kinematics
from .reference.likelihood import project_capsules
from .reference.raster import model_mask

_LEFT, _RIGHT, _MID = (60, 60, 230), (230, 120, 40), (60, 200, 60)


def _side_colour(name: str):
    return _LEFT if name.startswith("left") else _RIGHT if name.startswith("right") else _MID


def draw_view(background: np.ndarray, cam: Camera, q: np.ndarray, shape: BodyShape, U: np.ndarray,
              *, label: str = "") -> np.ndarray:
    """One camera's overlay (H, W, 3) uint8. ``background``: bool mask or grey/colour image."""
    h, w = cam.height, cam.width
    if background.dtype == bool:
        img = np.where(background[:h, :w, None], 150, 25).astype(np.uint8).repeat(3, axis=2)
    else:
        img = background if background.ndim == 3 else cv2.cvtColor(background, cv2.COLOR_GRAY2BGR)
        img = cv2.resize(img, (w, h), interpolation=cv2.INTER_AREA) if img.shape[:2] != (h, w) else img.copy()
    caps = project_capsules(q, shape.values, U, [cam])[0]
    model = model_mask(caps, h, w)
    tint = img.copy()
    tint[model] = (0.55 * tint[model] + 0.45 * np.array([40, 170, 240])).astype(np.uint8)
    img = tint
    thick = max(1, round(max(h, w) / 320))
    for s, name in enumerate(SEGMENT_NAMES):
        c = caps[s]
        if c[14] < 0.5:
            continue
        col = _side_colour(name)
        for x, y, r in (c[0:3], c[3:6]):
            cv2.circle(img, (int(round(x)), int(round(y))), max(1, int(round(r))), col, 1, cv2.LINE_AA)
        if c[14] > 1.5:
            quad = c[6:14].reshape(4, 2)
            for a, b in ((0, 3), (1, 2)):  # the two tangent sides
                cv2.line(img, tuple(np.round(quad[a]).astype(int)), tuple(np.round(quad[b]).astype(int)),
                         col, 1, cv2.LINE_AA)
    pts = forward_kinematics(q, shape.values, U).points
    uv, z, _ = project_points(cam, pts)
    for a, b in BONES:
        if z[POINT_INDEX[a]] > 0 and z[POINT_INDEX[b]] > 0:
            pa, pb = np.round(uv[POINT_INDEX[a]]).astype(int), np.round(uv[POINT_INDEX[b]]).astype(int)
            cv2.line(img, tuple(pa), tuple(pb), _side_colour(b), thick + 1, cv2.LINE_AA)
    for name, i in POINT_INDEX.items():
        if z[i] > 0:
            cv2.circle(img, tuple(np.round(uv[i]).astype(int)), thick + 1, (255, 255, 255), -1, cv2.LINE_AA)
    if label:
        cv2.putText(img, label, (4, 14 * thick), cv2.FONT_HERSHEY_SIMPLEX, 0.4 * thick, (255, 255, 255), 1,
                    cv2.LINE_AA)
    return img


def compose(views: list[np.ndarray]) -> np.ndarray:
    """Side by side (two rows when there are more than three views), padded to equal heights."""
    h = max(v.shape[0] for v in views)
    views = [np.pad(v, ((0, h - v.shape[0]), (0, 0), (0, 0))) for v in views]
    if len(views) <= 3:
        return np.hstack(views)
    half = (len(views) + 1) // 2
    top, bottom = views[:half], views[half:]
    w_top = sum(v.shape[1] for v in top)
    row2 = np.hstack(bottom)
    row2 = np.pad(row2, ((0, 0), (0, w_top - row2.shape[1]), (0, 0)))
    return np.vstack([np.hstack(top), row2])


def frame_overlay(backgrounds, cameras, q, shape, U, weight=None, frame=None) -> np.ndarray:
    views = []
    for k, (bg, cam) in enumerate(zip(backgrounds, cameras)):
        label = f"{cam.name}" + (f"  frame {frame}" if frame is not None and k == 0 else "") + \
                (f"  w={weight:.3f}" if weight is not None and k == 0 else "")
        views.append(draw_view(bg, cam, q, shape, U, label=label))
    return compose(views)


def save_frame_overlay(out_dir: Path, frame: int, backgrounds, cameras, q, shape, U, weight=None) -> Path:
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    path = out_dir / f"frame{frame:05d}.png"
    cv2.imwrite(str(path), frame_overlay(backgrounds, cameras, q, shape, U, weight, frame))
    return path
