"""Backgrounds without an empty-room clip, shadow suppression, and a mask-quality figure.

**Stable background** (:func:`stable_background`). The temporal median of a clip takes in a person
who stays put. Here each of ``segments`` stretches of the recording gives its own median, and any
other clip of the same still camera (``also``: a calibration-board clip, an earlier take) gives
one more. Where all these candidates agree the pixel is background. Where they disagree some
candidates hold something that stayed there for a while (the seated person in the recording, the
board in the calibration clip): there the candidate that best continues the background around
the region (the region inpainted from its surroundings) is taken, one candidate for each solid
region. A person who never moves in the recording cannot be told from the background by the
recording alone; one other clip without them in that spot is enough.

**Shadows** (:func:`shadow_mask`): a foreground pixel darker than the background by a factor in
``[SHADOW_LOW, SHADOW_HIGH]`` with nearly the same hue and saturation is a cast shadow (the rule
of OpenCV's MOG2 shadow detector), and is dropped with ``"shadows": true``.

**Mask quality** (:func:`mask_quality`): per camera, the share of frames whose largest blob holds
most of the foreground, the share of empty frames, and the median foreground fraction: masks
that are clutter show before anyone trusts a fit to them.
"""
from __future__ import annotations

import cv2
import numpy as np

from ..errors import require
from .silhouette import median_background

AGREE = 25  # grey levels: candidates closer than this (every channel) show the same thing
SEGMENTS = 8
FRAMES_PER_SEGMENT = 5
SHADOW_LOW, SHADOW_HIGH = 0.45, 0.92  # brightness ratio of a shadow to the background
SHADOW_HUE, SHADOW_SAT = 12, 40  # hue (0..180) and saturation (0..255) a shadow keeps
DOMINANT = 0.9  # a mask is "one blob" when its largest component holds this share


def segment_medians(reader, segments: int = SEGMENTS, per_segment: int = FRAMES_PER_SEGMENT):
    """(S, H, W, 3) medians of ``segments`` equal stretches of a clip (``per_segment`` frames each)."""
    n = reader.frame_count
    segments = max(1, min(segments, n))
    edges = np.linspace(0, n, segments + 1).round().astype(int)
    return np.stack([median_background(reader, per_segment, start=a, stop=b)
                     for a, b in zip(edges[:-1], edges[1:]) if b > a])


def board_region(image: np.ndarray, board) -> np.ndarray:
    """(H, W) bool: a calibration board in ``image``: its corners' hull grown by 2.5 squares (the
    outer squares and the margin) and the white paper joined to it, or all False when no board
    is found."""
    from .checkerboard import detect

    out = np.zeros(image.shape[:2], bool)
    found = detect(image, board)
    if found is None:
        return out
    uv = found[1].astype(np.float64)
    hull = cv2.convexHull(uv.astype(np.float32)).reshape(-1, 2)
    c = hull.mean(0)
    # a square's size in pixels: the mean distance between neighbouring corners
    step = np.median(np.linalg.norm(np.diff(uv.reshape(board.rows, board.cols, 2), axis=1),
                                    axis=2))
    grown = c + (hull - c) * (1 + 2.5 * step / np.maximum(np.linalg.norm(hull - c, axis=1,
                                                                          keepdims=True), 1))
    mask = np.zeros(image.shape[:2], np.uint8)
    cv2.fillPoly(mask, [np.round(grown).astype(np.int32)], 1)
    # and the white paper the squares are printed on, wherever it reaches
    hsv = cv2.cvtColor(image, cv2.COLOR_BGR2HSV)
    paper = ((hsv[..., 1] < 70) & (hsv[..., 2] > 150)).astype(np.uint8)
    n, labels = cv2.connectedComponents(paper | mask, connectivity=8)
    touched = np.unique(labels[mask > 0])
    region = np.isin(labels, touched[touched > 0])
    return cv2.dilate(region.astype(np.uint8), np.ones((7, 7), np.uint8)) > 0


def stable_background(reader, also=(), *, board=None, segments: int = SEGMENTS,
                      per_segment: int = FRAMES_PER_SEGMENT, agree: float = AGREE) -> np.ndarray:
    """(H, W, 3) uint8 background of a still camera (see module doc).

    reader : the recording (:class:`ipf_jax.data.video.VideoReader` or colour ImageSequence).
    also : other clips of the same camera (readers) without the person: their median is the
        background (the recording is then not used).
    board : a :class:`ipf_jax.data.checkerboard.Board` lying in the ``also`` clips (a calibration
        clip): the board's region of each clip is not valid there; where no clip is valid, the
        surrounding background is inpainted.
    """
    cands = [segment_medians(reader, segments, per_segment)]
    if also:
        acc = np.zeros((reader.height, reader.width, 3))
        weight = np.zeros((reader.height, reader.width))
        for other in also:
            require((other.width, other.height) == (reader.width, reader.height),
                    f"background clip is {other.width}x{other.height}, the recording "
                    f"{reader.width}x{reader.height}", getattr(other, "path", None))
            med = median_background(other, 2 * per_segment + 1)
            valid = ~board_region(med, board) if board is not None else np.ones(weight.shape, bool)
            acc[valid] += med[valid]
            weight[valid] += 1
        out = np.rint(acc / np.maximum(weight, 1)[..., None]).astype(np.uint8)
        hole = (weight == 0).astype(np.uint8)
        # where no clip shows the background (the board lay where the person later stands, as a
        # board defining the world origin does) the floor around it is continued inwards
        return cv2.inpaint(out, hole, 9, cv2.INPAINT_TELEA) if hole.any() else out
    cand = np.concatenate(cands).astype(np.int16)  # (C, H, W, 3)
    ref = np.median(cand, axis=0)
    spread = np.abs(cand - ref[None]).max(axis=(0, 3))  # (H, W): worst candidate vs the median
    unsure = (spread > agree).astype(np.uint8)
    unsure = cv2.dilate(unsure, np.ones((5, 5), np.uint8))  # region edges are blurred
    out = np.rint(ref).astype(np.uint8)
    if not unsure.any():
        return out
    guess = cv2.inpaint(out, unsure, 7, cv2.INPAINT_TELEA).astype(np.int16)
    region = unsure > 0
    cost = np.abs(cand[:, region] - guess[region][None]).sum(axis=2)  # (C, P)
    choice = np.zeros(unsure.shape, np.uint8)
    choice[region] = np.argmin(cost, axis=0)  # thin edges and specks: pixel by pixel
    # solid regions (an opening cuts the thin edges that would join them) take one candidate
    # as a whole: the feet and the shadow of a seated person match the dark ground around them
    # pixel by pixel, but not the person as a whole
    cores = cv2.morphologyEx(unsure, cv2.MORPH_OPEN, np.ones((7, 7), np.uint8))
    n, labels = cv2.connectedComponents(cores, connectivity=8)
    for k in range(1, n):
        blob = labels == k
        total = np.abs(cand[:, blob] - guess[blob][None]).mean(axis=(1, 2))  # (C,)
        grown = cv2.dilate(blob.astype(np.uint8), np.ones((7, 7), np.uint8)) > 0
        choice[grown & region] = int(np.argmin(total))
    rows, cols = np.nonzero(region)
    out[rows, cols] = cand[choice[rows, cols], rows, cols]
    return out


def shadow_mask(frame: np.ndarray, background: np.ndarray) -> np.ndarray:
    """(H, W) bool: pixels that look like a shadow cast on the background (see module doc)."""
    f = cv2.cvtColor(frame, cv2.COLOR_BGR2HSV).astype(np.int16)
    b = cv2.cvtColor(background, cv2.COLOR_BGR2HSV).astype(np.int16)
    ratio = (f[..., 2] + 1) / (b[..., 2] + 1)
    dh = np.abs(f[..., 0] - b[..., 0])
    dh = np.minimum(dh, 180 - dh)
    return (ratio >= SHADOW_LOW) & (ratio <= SHADOW_HIGH) & (dh <= SHADOW_HUE) \
        & (np.abs(f[..., 1] - b[..., 1]) <= SHADOW_SAT)


def iou(a: np.ndarray, b: np.ndarray) -> float:
    """Intersection over union of two (H, W) bool masks (1 when both are empty)."""
    union = np.logical_or(a, b).sum()
    return 1.0 if union == 0 else float(np.logical_and(a, b).sum() / union)


def frame_quality(masks, stats: list | None = None) -> list[list]:
    """One frame's mask figures, per camera ``[area_px, foreground_share, blobs, one_blob]``:
    blobs are 8-connected components of at least 0.1 % of the foreground, ``one_blob`` whether
    the largest holds at least :data:`DOMINANT` of it. ``stats``: per mask the components' stats
    of its bool mask (``cv2.connectedComponentsWithStats``) or None, when the caller has them."""
    out = []
    for m, found in zip(masks, stats or [None] * len(masks)):
        m = np.asarray(m, bool)
        area = int(m.sum())
        if area == 0:
            out.append([0, 0.0, 0, False])
            continue
        if found is None:
            _, _, found, _ = cv2.connectedComponentsWithStats(m.astype(np.uint8), connectivity=8)
        areas = found[1:, cv2.CC_STAT_AREA]
        out.append([area, round(area / m.size, 6), int((areas >= 0.001 * area).sum()),
                    bool(areas.max() >= DOMINANT * area)])
    return out


def quality_summary(frames: list[list[list]], names=None) -> list[dict]:
    """Per camera, over frames of :func:`frame_quality` rows: ``frames``, ``empty_share``,
    ``one_blob_share`` (over non-empty frames), ``median_foreground``, ``median_blobs``."""
    require(bool(frames) and bool(frames[0]), "no masks were added")
    out = []
    for k in range(len(frames[0])):
        rows = [f[k] for f in frames]
        filled = [r for r in rows if r[0] > 0]
        fig = {"frames": len(rows), "empty_share": round(1 - len(filled) / len(rows), 4),
               "one_blob_share": round(sum(r[3] for r in filled) / len(filled), 4) if filled else 0.0,
               "median_foreground": round(float(np.median([r[1] for r in rows])), 5),
               "median_blobs": float(np.median([r[2] for r in rows]))}
        out.append({"camera": names[k], **fig} if names else fig)
    return out


class MaskQuality:
    """Per-camera mask-quality figures gathered frame by frame (see :func:`mask_quality`):
    ``add(masks)`` takes one frame's masks, one (H, W) bool array per camera; ``summary(names)``
    returns one dict per camera (:func:`quality_summary`)."""

    def __init__(self):
        self._frames: list[list[list]] = []

    def add(self, masks) -> None:
        masks = list(masks)
        if self._frames:
            require(len(masks) == len(self._frames[0]),
                    f"{len(masks)} masks for {len(self._frames[0])} cameras")
        self._frames.append(frame_quality(masks))

    def summary(self, names=None) -> list[dict]:
        return quality_summary(self._frames, names)


def mask_quality(masks) -> dict:
    """Quality figures of one camera's masks over frames.

    masks : iterable of (H, W) bool masks (one camera, T frames).
    Returns ``frames``, ``empty_share``, ``one_blob_share`` (largest 8-connected blob holds at
    least :data:`DOMINANT` of the foreground, over non-empty frames), ``median_foreground`` (share
    of the image), ``median_blobs`` (components of at least 0.1 % of the foreground).
    """
    acc = MaskQuality()
    for m in masks:
        acc.add([m])
    require(bool(acc._frames), "mask_quality needs at least one mask")
    return acc.summary()[0]
