"""Frames that are a crop of the calibrated sensor image (``crop`` in dataset.json).

A video camera often records a window of its sensor: a calibration for 1088 x 1920 and frames of
1080 x 1920 (QTM's Miqus video, 8 columns fewer). Cropping leaves focal lengths and distortion
alone and moves the principal point by the pixels removed at the left and top edges.

* Without a ``crop`` entry, frames at most :data:`AUTO_CROP` (1 %) narrower or shorter are read as
  the image cut at the **right and bottom** (principal point unchanged), with a warning naming the
  difference; more than that is an error.
* ``"crop"`` (per camera, or at the top level for all) says where the pixels went: a list of edge
  names (``["left"]``, ``["top", "bottom"]``: an axis with both edges named loses half on each
  side, the odd pixel at the right/bottom), or ``{"left": px, "top": px}`` for exact offsets (the
  rest of each difference is at the right/bottom). With a ``crop`` entry any crop is allowed and
  nothing is printed.
"""
from __future__ import annotations

import warnings
from dataclasses import replace
from pathlib import Path

from ..errors import IPFError, IPFWarning, require
from ..geometry.camera import Camera

AUTO_CROP = 0.01  # fraction of the calibrated width/height read as a right/bottom crop
EDGES = ("left", "right", "top", "bottom")


def _offsets(crop, dw: int, dh: int, where: str, doc_path) -> tuple[int, int]:
    """(pixels removed at the left, at the top) for a ``crop`` entry."""
    if isinstance(crop, str):
        crop = [crop]
    if isinstance(crop, list):
        bad = [e for e in crop if e not in EDGES]
        require(not bad and crop, f"{where} crop must list edges among {', '.join(EDGES)} or be "
                f"{{\"left\": px, \"top\": px}}, got {crop!r}", doc_path)
        left = dw // 2 if {"left", "right"} <= set(crop) else dw if "left" in crop else 0
        top = dh // 2 if {"top", "bottom"} <= set(crop) else dh if "top" in crop else 0
        return left, top
    if isinstance(crop, dict):
        bad = sorted(set(crop) - {"left", "top"})
        require(not bad, f"{where} crop: unknown key(s) {', '.join(map(str, bad))} (left, top)",
                doc_path)
        out = []
        for key, d in (("left", dw), ("top", dh)):
            v = crop.get(key, 0)
            require(isinstance(v, int) and not isinstance(v, bool) and 0 <= v <= d,
                    f"{where} crop {key} must be a whole number of pixels in 0..{d}, got {v!r}",
                    doc_path)
            out.append(v)
        return out[0], out[1]
    raise IPFError(f"{where} crop must be a list of edges or {{\"left\": px, \"top\": px}}, got "
                   f"{crop!r}", doc_path)


def crop_camera(cam: Camera, w: int, h: int, crop=None, *, where: str = "camera",
                calib: Path | str | None = None, doc_path: Path | str | None = None) -> Camera:
    """The camera seen through a ``w`` x ``h`` window of its calibrated image (see module doc)."""
    dw, dh = cam.width - w, cam.height - h
    size = f"frames are {w}x{h} but camera {cam.name!r} is calibrated at {cam.width}x{cam.height}"
    require(dw >= 0 and dh >= 0, f"{where}: {size} (frames larger than the calibrated image, and "
            "not the same aspect ratio)", calib)
    if crop is None:
        require(dw <= AUTO_CROP * cam.width and dh <= AUTO_CROP * cam.height,
                f"{where}: {size} (not the same aspect ratio, and more than "
                f"{AUTO_CROP:.0%} smaller: give a 'crop' entry if the frames are a window of the "
                "sensor, see docs/formats.md)", calib)
        left = top = 0
        cut = " and ".join(s for s in (f"{dw} px at the right" if dw else "",
                                       f"{dh} px at the bottom" if dh else "") if s)
        warnings.warn(IPFWarning(f"{where}: {size}: read as that image with {cut} cut off "
                                 "(principal point unchanged; a 'crop' entry in dataset.json "
                                 "names other edges)"), stacklevel=3)
    else:
        left, top = _offsets(crop, dw, dh, where, doc_path)
    K = cam.K.copy()
    K[0, 2] -= left
    K[1, 2] -= top
    return replace(cam, K=K, width=int(w), height=int(h))
