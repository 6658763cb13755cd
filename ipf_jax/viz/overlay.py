"""Overlays: the fitted capsules and skeleton drawn over each camera's mask or image.

On a **mask** the three pixel sets of the likelihood are coloured: silhouette only (``Ns``) grey,
silhouette and model (``Nc``) pale blue, model only (``Nm``) orange, so a misfit shows where it
is. On a **camera image** the model is tinted orange and the silhouette (when given) outlined in
yellow. Capsule outlines and bones: subject's left red, right blue, trunk and head green; key
points white. Views are drawn at any size (the camera is scaled with the image) and composed side
by side. Colours are BGR (OpenCV).
"""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from ..body.model import BONES, POINT_INDEX, SEGMENT_NAMES
from ..body.shape import BodyShape
from ..geometry.camera import Camera
from ..geometry.host import forward_kinematics, project_capsules, project_points
from ..likelihood.model_mask import model_mask

LEFT, RIGHT, MID = (60, 60, 230), (230, 120, 40), (60, 200, 60)
SILHOUETTE, OVERLAP, MODEL_ONLY = (120, 120, 120), (235, 200, 160), (40, 140, 255)
OUTLINE = (0, 230, 255)
_SUB = 4  # fractional bits of OpenCV's sub-pixel drawing
LEGEND = "grey: silhouette only (Ns)  blue: both (Nc)  orange: model only (Nm)"


def side_colour(name: str) -> tuple[int, int, int]:
    return LEFT if name.startswith("left") else RIGHT if name.startswith("right") else MID


def _fixed(xy) -> tuple[int, int]:
    return tuple(int(round(v * (1 << _SUB))) for v in xy)


def model_silhouette(caps: np.ndarray, height: int, width: int) -> np.ndarray:
    """(S, 15) capsule records -> (height, width) bool: the model's pixels as the likelihood counts
    them (the exact reference raster), computed in the capsules' bounding box only."""
    out = np.zeros((height, width), bool)
    drawn = caps[caps[:, 14] > 0.5]
    if len(drawn) == 0:
        return out
    x = np.concatenate([drawn[:, [0, 3]] - drawn[:, [2, 5]], drawn[:, [0, 3]] + drawn[:, [2, 5]],
                        drawn[:, 6:14:2]], axis=1)
    y = np.concatenate([drawn[:, [1, 4]] - drawn[:, [2, 5]], drawn[:, [1, 4]] + drawn[:, [2, 5]],
                        drawn[:, 7:14:2]], axis=1)
    c0, c1 = max(int(np.floor(x.min())) - 1, 0), min(int(np.ceil(x.max())) + 2, width)
    r0, r1 = max(int(np.floor(y.min())) - 1, 0), min(int(np.ceil(y.max())) + 2, height)
    if c0 >= c1 or r0 >= r1:
        return out
    shifted = drawn.copy()
    shifted[:, [0, 3, 6, 8, 10, 12]] -= c0
    shifted[:, [1, 4, 7, 9, 11, 13]] -= r0
    out[r0:r1, c0:c1] = model_mask(shifted, r1 - r0, c1 - c0)
    return out


def _base(background: np.ndarray, h: int, w: int, model: np.ndarray,
          mask: np.ndarray | None) -> np.ndarray:
    """The coloured pixels under the lines: likelihood sets on a mask, tint and outline on an image."""
    background = np.asarray(background)
    if background.dtype == bool:
        sil = _resize_mask(background, h, w)
        img = np.full((h, w, 3), 25, np.uint8)
        img[sil & ~model] = SILHOUETTE
        img[sil & model] = OVERLAP
        img[~sil & model] = MODEL_ONLY
        return img
    img = background if background.ndim == 3 else cv2.cvtColor(background, cv2.COLOR_GRAY2BGR)
    img = cv2.resize(img, (w, h), interpolation=cv2.INTER_AREA) if img.shape[:2] != (h, w) \
        else img.copy()
    img[model] = (0.6 * img[model] + 0.4 * np.array(MODEL_ONLY)).astype(np.uint8)
    if mask is not None:
        contours, _ = cv2.findContours(_resize_mask(mask, h, w).astype(np.uint8), cv2.RETR_EXTERNAL,
                                       cv2.CHAIN_APPROX_SIMPLE)
        cv2.drawContours(img, contours, -1, OUTLINE, 1, cv2.LINE_AA)
    return img


def _resize_mask(mask: np.ndarray, h: int, w: int) -> np.ndarray:
    mask = np.asarray(mask, bool)
    if mask.shape == (h, w):
        return mask
    return cv2.resize(mask.astype(np.uint8), (w, h), interpolation=cv2.INTER_NEAREST).astype(bool)


def put_label(img: np.ndarray, text: str, row: int = 0) -> None:
    """White text on a dark band at the top-left (``row`` counts lines), in place."""
    scale = max(0.4, img.shape[1] / 1400)
    (tw, th), base = cv2.getTextSize(text, cv2.FONT_HERSHEY_SIMPLEX, scale, 1)
    y0 = 4 + row * (th + base + 6)
    cv2.rectangle(img, (2, y0), (8 + tw, y0 + th + base + 4), (0, 0, 0), -1)
    cv2.putText(img, text, (5, y0 + th + 2), cv2.FONT_HERSHEY_SIMPLEX, scale, (255, 255, 255), 1,
                cv2.LINE_AA)


def draw_view(background: np.ndarray, cam: Camera, q: np.ndarray | None, shape: BodyShape,
              U: np.ndarray, *, mask: np.ndarray | None = None, labels: tuple[str, ...] = (),
              long_side: int | None = None) -> np.ndarray:
    """One camera's overlay, (H, W, 3) uint8 BGR.

    background : (h, w) bool mask, (h, w) uint8 grey or (h, w, 3) uint8 image, at any resolution
        with the camera's aspect ratio.
    cam : the camera (any resolution); q : (D,) pose, or None / NaN for a frame without one.
    mask : (h, w) bool silhouette to outline on an image background.
    labels : text lines drawn at the top-left.  long_side : view size (default: the camera's).
    """
    if long_side is not None and long_side != max(cam.width, cam.height):
        cam = cam.scaled(long_side / max(cam.width, cam.height))
    h, w = cam.height, cam.width
    have_pose = q is not None and bool(np.all(np.isfinite(q)))
    caps = project_capsules(q, shape.values, U, [cam])[0] if have_pose else np.zeros((0, 15))
    img = _base(background, h, w, model_silhouette(caps, h, w), mask)
    thick = max(1, round(max(h, w) / 400))
    for name, c in zip(SEGMENT_NAMES, caps):
        if c[14] < 0.5:
            continue
        col = side_colour(name)
        for x, y, r in (c[0:3], c[3:6]):
            cv2.circle(img, _fixed((x, y)), int(round(r * (1 << _SUB))), col, 1, cv2.LINE_AA, _SUB)
        if c[14] > 1.5:
            quad = c[6:14].reshape(4, 2)
            for a, b in ((0, 3), (1, 2)):  # the two tangent sides
                cv2.line(img, _fixed(quad[a]), _fixed(quad[b]), col, 1, cv2.LINE_AA, _SUB)
    if have_pose:
        uv, z, _ = project_points(cam, forward_kinematics(q, shape.values, U).points)
        for a, b in BONES:
            ia, ib = POINT_INDEX[a], POINT_INDEX[b]
            if z[ia] > 0 and z[ib] > 0:
                cv2.line(img, _fixed(uv[ia]), _fixed(uv[ib]), side_colour(b), thick + 1,
                         cv2.LINE_AA, _SUB)
        for i in np.nonzero(z > 0)[0]:
            cv2.circle(img, _fixed(uv[i]), (thick + 1) << _SUB, (255, 255, 255), -1, cv2.LINE_AA,
                       _SUB)
    for row, text in enumerate(labels):
        put_label(img, text, row)
    return img


def compose(views: list[np.ndarray], *, even: bool = False) -> np.ndarray:
    """Side by side (two rows when there are more than three views), padded to equal heights.

    even : pad the result to even width and height (what video encoders need).
    """
    h = max(v.shape[0] for v in views)
    views = [np.pad(v, ((0, h - v.shape[0]), (0, 0), (0, 0))) for v in views]
    if len(views) <= 3:
        out = np.hstack(views)
    else:
        half = (len(views) + 1) // 2
        rows = [np.hstack(views[:half]), np.hstack(views[half:])]
        width = max(r.shape[1] for r in rows)  # either row may be the wider (portrait + landscape)
        out = np.vstack([np.pad(r, ((0, 0), (0, width - r.shape[1]), (0, 0))) for r in rows])
    if even:
        out = np.pad(out, ((0, out.shape[0] % 2), (0, out.shape[1] % 2), (0, 0)))
    return out


def frame_overlay(backgrounds, cameras, q, shape, U, weight=None, frame=None, *, masks=None,
                  long_side: int | None = None, status: str | None = None,
                  legend: bool = False, even: bool = False) -> np.ndarray:
    """Every camera's view of one frame, composed (see :func:`draw_view`, :func:`compose`). The
    first view carries the frame number, the frame's weight (or status) and, with ``legend``, the
    colour key of mask backgrounds."""
    views = []
    for k, (bg, cam) in enumerate(zip(backgrounds, cameras)):
        labels = [cam.name]
        if k == 0:
            info = [f"frame {frame}"] if frame is not None else []
            info += [f"w = {weight:.3f}"] if weight is not None else []
            info += [status] if status else []
            labels = [f"{cam.name}  " + "  ".join(info)]
            if legend and np.asarray(bg).dtype == bool:
                labels.append(LEGEND)
        views.append(draw_view(bg, cam, q, shape, U, mask=None if masks is None else masks[k],
                               labels=tuple(labels), long_side=long_side))
    return compose(views, even=even)


def save_frame_overlay(out_dir: Path, frame: int, backgrounds, cameras, q, shape, U,
                       weight=None) -> Path:
    """Write ``out_dir/frameNNNNN.png`` (what ``ipf-jax track --overlay`` does per frame)."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    path = out_dir / f"frame{frame:05d}.png"
    small = max(max(c.width, c.height) for c in cameras) < 480  # scoring-size masks: enlarge
    cv2.imwrite(str(path), frame_overlay(backgrounds, cameras, q, shape, U, weight, frame,
                                         long_side=480 if small else None))
    return path


def overlay_writer(out_dir: Path):
    """A tracker frame hook (:class:`ipf_jax.tracking.tracker.FrameView` -> PNG) writing
    ``out_dir/frameNNNNN.png`` for every tracked frame (``ipf-jax track --overlay``)."""
    def write(view) -> None:
        save_frame_overlay(out_dir, view.frame, view.masks, view.cameras, view.pose, view.shape,
                           view.up, view.weight)
    return write
