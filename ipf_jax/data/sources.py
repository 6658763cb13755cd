"""Per-camera frame sources of the ``dataset.json`` layout (format: docs/formats.md).

A camera's silhouettes come from one of:

* ``masks``: a folder of numbered masks, used as they are (optionally ``images`` beside them for
  overlays);
* ``images`` + ``background``: a folder of numbered camera images and a background (an image, a
  background video or image folder, or the temporal median of the images themselves);
* ``video`` + optional ``background``: a video file; without a background, the temporal median of
  K frames sampled from the video (only those K frames are ever held in memory).

Every source exposes ``frames`` (frame numbers), ``fps`` (None when unknown), ``size`` (W, H),
``mask(frame) -> (H, W) bool`` and ``image(frame) -> (H, W, 3) uint8 BGR or None``. Subtraction
sources then keep the region of interest (``roi``: pixels outside it are never foreground, which
is how a second person elsewhere in the view is ignored) and, with ``cover``, only the largest
blobs. ``max_foreground`` empties a mask whose foreground exceeds that fraction of the region of
interest: a global lighting change (auto-exposure, the sun) is not a person, and an empty mask
makes the tracker record the frame as missing instead of fitting the model to it.

:func:`build_sources` reads the calibration, pairs cameras with their entries and applies the
camera options (``camera_height``); it is what :func:`ipf_jax.data.dataset.open_described` calls.
"""
from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

import cv2
import numpy as np

from ..errors import IPFError, require
from ..geometry.camera import Camera
from ..geometry.world import AXES, axis_vector, detect_up_axis
from ..paths import shared_data_dir
from .calibration import distinct_names, read_calibration
from .frames import parse_frames, select_frames
from .silhouette import (
    CLOSE_PX,
    OPEN_PX,
    THRESHOLD,
    foreground,
    largest_components,
    median_background,
    read_color,
)
from .video import ImageSequence, VideoReader

MEDIAN_FRAMES = 25  # frames sampled for a temporal-median background: enough for a pixel to show
# the background in most samples while a person walks through, few enough to hold in memory
PERSON_FRAMES = 15  # frames sampled to place a camera from the person's silhouette
_IMAGE_EXT = (".png", ".bmp", ".jpg", ".jpeg", ".tif", ".tiff")
_TOP_KEYS = {"format", "version", "description", "calibration", "calibration_units", "cameras",
             "fps", "up_axis", "frames", "height_m", "camera_height", "segmentation", "crop"}
_CAMERA_KEYS = {"name", "masks", "images", "video", "background", "prefix", "roi", "segmentation",
                "camera_height", "crop"}
_SEG_KEYS = {"threshold", "open_px", "close_px", "cover", "max_foreground", "shadows"}


class Segmentation(NamedTuple):
    """Background subtraction and clean-up settings (see :func:`ipf_jax.data.silhouette.foreground`).

    roi : (H, W) bool region of interest or None (whole image).
    max_foreground : fraction of the region of interest above which a mask is emptied, or None.
    """

    threshold: float = THRESHOLD
    open_px: int = OPEN_PX
    close_px: int = CLOSE_PX
    cover: float | None = None
    max_foreground: float | None = None
    roi: np.ndarray | None = None
    shadows: bool = False  # drop cast shadows (ipf_jax.background_model.shadow_mask)


def clean_mask(mask: np.ndarray, seg: Segmentation) -> np.ndarray:
    """(H, W) bool foreground -> region of interest, largest blobs, lighting-change guard."""
    if seg.roi is not None:
        mask = mask & seg.roi
    if seg.max_foreground is not None:
        area = int(seg.roi.sum()) if seg.roi is not None else mask.size
        if mask.sum() > seg.max_foreground * area:
            return np.zeros_like(mask)
    if seg.cover is not None:  # after the ROI, so a bigger blob outside it cannot win
        mask = largest_components(mask, seg.cover)
    return mask


class _Cached:
    """Keeps the last frame asked for: the tracker reads the first frame twice, overlays read the
    image a mask came from."""

    def __init__(self, fn):
        self._fn, self._key, self._value = fn, None, None

    def __call__(self, frame: int):
        if self._key != frame:
            self._value, self._key = self._fn(frame), frame
        return self._value


class MaskSource:
    """Numbered masks used as they are; ``images`` (same numbers) only for overlays."""

    def __init__(self, folder: Path, *, prefix: str | None = "image", images: Path | None = None,
                 seg: Segmentation = Segmentation()):
        self.path = folder
        self._masks = ImageSequence(folder, prefix, mode="mask")
        self._images = None if images is None else ImageSequence(images, prefix, mode="color")
        if self._images is not None:
            require(self._images.frame_numbers == self._masks.frame_numbers,
                    f"the image folder's frame numbers differ from those of the masks in {folder}",
                    images)
        self.frames = list(self._masks.frame_numbers)
        self._index = {f: i for i, f in enumerate(self.frames)}
        self.size = (self._masks.width, self._masks.height)
        self.fps = None
        self.seg = seg
        self.mask = _Cached(lambda f: clean_mask(self._masks.read(self._index[f]), self.seg))

    def image(self, frame: int) -> np.ndarray | None:
        return None if self._images is None else self._images.read(self._index[frame])

    def file(self, frame: int) -> Path:
        """The mask file of ``frame`` (named in errors)."""
        return self._masks.files[self._index[frame]]


class SubtractionSource:
    """Camera images (a video or an image folder) minus a background image.

    reader : a :class:`ipf_jax.data.video.VideoReader` or colour :class:`ipf_jax.data.video.ImageSequence`.
    background : a callable returning the (H, W, 3) uint8 background; called once, on first use
        (so opening a dataset for its cameras alone costs no median).
    """

    def __init__(self, reader, background, *, seg: Segmentation = Segmentation()):
        self.path = reader.path
        self.reader = reader
        self.frames = list(reader.frame_numbers)
        self._index = {f: i for i, f in enumerate(self.frames)}
        self.size = (reader.width, reader.height)
        self.fps = reader.fps
        self.seg = seg
        self._background_fn, self._background = background, None
        # frames() decodes forward over short gaps: a seek decodes from the previous keyframe
        self.image = _Cached(lambda f: next(iter(reader.frames([self._index[f]])))[1])
        self.mask = _Cached(self._segment)

    @property
    def background(self) -> np.ndarray:
        if self._background is None:
            bg = self._background_fn()
            require(bg.shape[:2] == (self.reader.height, self.reader.width),
                    f"background is {bg.shape[1]}x{bg.shape[0]}, the frames are "
                    f"{self.reader.width}x{self.reader.height}", self.path)
            self._background = bg
        return self._background

    def _segment(self, frame: int) -> np.ndarray:
        s = self.seg
        image, bg = self.image(frame), self.background
        if s.shadows:  # shadows leave before the clean-up, so it closes no hole over them
            from .background_model import shadow_mask

            fg = foreground(image, bg, s.threshold, open_px=0, close_px=0)
            return clean_mask(_cleaned(fg & ~shadow_mask(image, bg), s), s)
        if s.roi is None:
            return clean_mask(foreground(image, bg, s.threshold, open_px=s.open_px,
                                         close_px=s.close_px), s)
        # subtract inside the ROI's bounding box only (a margin keeps the clean-up's borders out)
        rows, cols = np.nonzero(s.roi.any(axis=1))[0], np.nonzero(s.roi.any(axis=0))[0]
        pad = s.open_px + s.close_px  # the reach of an opening then a closing
        r0, r1 = max(rows[0] - pad, 0), min(rows[-1] + 1 + pad, image.shape[0])
        c0, c1 = max(cols[0] - pad, 0), min(cols[-1] + 1 + pad, image.shape[1])
        fg = np.zeros(image.shape[:2], bool)
        fg[r0:r1, c0:c1] = foreground(image[r0:r1, c0:c1], bg[r0:r1, c0:c1], s.threshold,
                                      open_px=s.open_px, close_px=s.close_px)
        return clean_mask(fg, s)


def _cleaned(fg: np.ndarray, s: Segmentation) -> np.ndarray:
    """The opening then closing of :func:`ipf_jax.silhouette.foreground`, on a mask."""
    out = fg.astype(np.uint8)
    for px, op in ((s.open_px, cv2.MORPH_OPEN), (s.close_px, cv2.MORPH_CLOSE)):
        if px > 1:
            out = cv2.morphologyEx(out, op, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (px, px)))
    return out.astype(bool)


# --- parsing dataset.json ------------------------------------------------------------------------

def resolve(root: Path, value, what: str, doc_path: Path) -> Path:
    """A path from dataset.json: relative to its folder; ``$IPF_JAX_DATA/...`` is the shared data."""
    require(isinstance(value, str) and value.strip() != "", f"{what} must be a path string", doc_path)
    if value.startswith("$IPF_JAX_DATA"):
        return shared_data_dir() / value[len("$IPF_JAX_DATA"):].lstrip("/\\")
    p = Path(value).expanduser()
    return p if p.is_absolute() else root / p


def _number(value, what: str, doc_path: Path, *, lo: float, hi: float, integer: bool = False):
    ok = isinstance(value, (int, float)) and not isinstance(value, bool) and np.isfinite(value) \
        and lo <= value <= hi and (not integer or float(value).is_integer())
    require(ok, f"{what} must be {'an integer' if integer else 'a number'} in {lo:g}..{hi:g}, "
            f"got {value!r}", doc_path)
    return int(value) if integer else float(value)


def roi_mask(value, width: int, height: int, where: str, doc_path: Path) -> np.ndarray:
    """``[x0, y0, x1, y1]`` rectangle or ``[[x, y], ...]`` polygon (pixels, full resolution)."""
    try:
        pts = np.asarray(value, float)
    except (TypeError, ValueError):
        pts = np.zeros((0,))
    if pts.shape == (4,):
        x0, y0, x1, y1 = pts
        require(x0 < x1 and y0 < y1, f"{where} roi [x0, y0, x1, y1] needs x0 < x1 and y0 < y1",
                doc_path)
        pts = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]])
    require(pts.ndim == 2 and pts.shape[1] == 2 and len(pts) >= 3 and np.all(np.isfinite(pts)),
            f"{where} roi must be [x0, y0, x1, y1] or a list of at least 3 [x, y] points",
            doc_path)
    out = np.zeros((height, width), np.uint8)
    cv2.fillPoly(out, [np.round(pts).astype(np.int32)], 1)
    require(bool(out.any()), f"{where} roi lies outside the {width}x{height} image", doc_path)
    return out.astype(bool)


def _segmentation(defaults: dict, entry: dict, where: str, doc_path: Path) -> dict:
    seg = {**defaults, **(entry.get("segmentation") or {})}
    bad = sorted(set(seg) - _SEG_KEYS)
    require(not bad, f"{where}: unknown segmentation option(s) {', '.join(bad)} "
            f"(known: {', '.join(sorted(_SEG_KEYS))})", doc_path)
    out = {}
    if "threshold" in seg:
        out["threshold"] = _number(seg["threshold"], f"{where} threshold", doc_path, lo=0, hi=255)
    for k in ("open_px", "close_px"):
        if k in seg:
            out[k] = _number(seg[k], f"{where} {k}", doc_path, lo=0, hi=99, integer=True)
    for k in ("cover", "max_foreground"):
        if seg.get(k) is not None:
            out[k] = _number(seg[k], f"{where} {k}", doc_path, lo=1e-6, hi=1.0)
    if "shadows" in seg:
        require(isinstance(seg["shadows"], bool), f"{where} shadows must be true or false, got "
                f"{seg['shadows']!r}", doc_path)
        out["shadows"] = seg["shadows"]
    return out


def _median_of(path: Path, k: int, sl: slice | None, prefix: str):
    def compute() -> np.ndarray:
        reader = ImageSequence(path, prefix, mode="color") if path.is_dir() else VideoReader(path)
        frames = list(reader.frame_numbers)
        chosen = select_frames(frames, sl, where="background 'frames'", path=path)
        require(bool(chosen), "the background frame range selects no frame", path)
        start, stop = frames.index(chosen[0]), frames.index(chosen[-1]) + 1
        return median_background(reader, k, start=start, stop=stop)
    return compute


def _stable_of(bg: dict, root: Path, own: Path, where: str, doc_path: Path, prefix: str):
    """``{"model": "stable", "also": [clips], "board": "8x6"}``: see ipf_jax.background_model."""
    require(bg["model"] == "stable", f"{where} background model must be \"median\" or "
            f"\"stable\", got {bg['model']!r}", doc_path)
    bad = sorted(set(bg) & {"source", "median", "frames"})
    require(not bad, f"{where}: a stable background takes no {', '.join(bad)}", doc_path)
    also = bg.get("also", [])
    also = [also] if isinstance(also, str) else also
    require(isinstance(also, list), f"{where} background also must be a path or a list of paths",
            doc_path)
    clips = [resolve(root, a, f"{where} background also", doc_path) for a in also]
    for c in clips:
        if not c.exists():
            raise IPFError(f"{where} background clip not found", c)
    board = None
    if "board" in bg:
        from .checkerboard import parse_board

        require(isinstance(bg["board"], str), f"{where} background board must look like \"8x6\"",
                doc_path)
        try:
            board = parse_board(bg["board"], 1.0)
        except IPFError as e:
            raise IPFError(f"{where} background board: {e.message}", doc_path) from None

    def compute() -> np.ndarray:
        from .background_model import stable_background

        def open_clip(p: Path):
            return ImageSequence(p, prefix, mode="color") if p.is_dir() else VideoReader(p)

        return stable_background(open_clip(own), [open_clip(c) for c in clips], board=board)
    return compute


def _background(entry: dict, root: Path, own: Path, where: str, doc_path: Path, prefix: str):
    """A callable returning the background image of one camera (see docs/formats.md)."""
    bg = entry.get("background")
    if bg is None or isinstance(bg, str):
        bg = {"median": MEDIAN_FRAMES} if bg is None else {"source": bg}
    require(isinstance(bg, dict), f"{where} background must be a path or an object", doc_path)
    bad = sorted(set(bg) - {"source", "median", "frames", "model", "also", "board"})
    require(not bad, f"{where} background: unknown key(s) {', '.join(bad)} (source, median, "
            "frames, model, also, board)", doc_path)
    if bg.get("model", "median") != "median":
        return _stable_of(bg, root, own, where, doc_path, prefix)
    src = own if "source" not in bg else resolve(root, bg["source"], f"{where} background", doc_path)
    if not src.exists():
        raise IPFError(f"{where} background not found", src)
    if src.suffix.lower() in _IMAGE_EXT and not src.is_dir():
        require(set(bg) == {"source"}, f"{where}: a background image takes no median/frames",
                doc_path)
        return lambda: read_color(src)
    k = _number(bg.get("median", MEDIAN_FRAMES), f"{where} background median", doc_path, lo=1,
                hi=1001, integer=True)
    sl = parse_frames(bg["frames"], f"{where} background 'frames'", doc_path) if "frames" in bg \
        else None
    return _median_of(src, k, sl, prefix)


def make_source(entry: dict, root: Path, where: str, doc_path: Path, seg_defaults: dict):
    """One camera's source from its dataset.json entry (see the module docstring)."""
    require(isinstance(entry, dict), f"{where} must be an object", doc_path)
    bad = sorted(set(entry) - _CAMERA_KEYS)
    require(not bad, f"{where}: unknown key(s) {', '.join(bad)} (known: "
            f"{', '.join(sorted(_CAMERA_KEYS))})", doc_path)
    kinds = [k for k in ("masks", "video") if k in entry] + \
        (["images"] if "images" in entry and "masks" not in entry else [])
    require(len(kinds) == 1, f"{where} needs exactly one of 'masks', 'images' or 'video' "
            f"(got {', '.join(kinds) or 'none'})", doc_path)
    prefix = entry.get("prefix", "image")
    require(isinstance(prefix, str), f"{where} prefix must be a string", doc_path)
    seg = _segmentation(seg_defaults, entry, where, doc_path)
    kind = kinds[0]
    if kind == "masks":
        require("background" not in entry, f"{where}: masks take no background", doc_path)
        used = sorted(set(seg) & {"threshold", "open_px", "close_px", "shadows"})
        require(not used, f"{where}: masks are used as they are ({', '.join(used)} apply to "
                "images and videos only)", doc_path)
        folder = resolve(root, entry["masks"], f"{where} masks", doc_path)
        images = resolve(root, entry["images"], f"{where} images", doc_path) if "images" in entry \
            else None
        return MaskSource(folder, prefix=prefix, images=images, seg=Segmentation(**seg)), seg
    own = resolve(root, entry[kind], f"{where} {kind}", doc_path)
    reader = VideoReader(own) if kind == "video" else ImageSequence(own, prefix, mode="color")
    return SubtractionSource(reader, _background(entry, root, own, where, doc_path, prefix),
                             seg=Segmentation(**seg)), seg


def _one_recording_each(entries: list[dict], root: Path, doc_path: Path) -> None:
    """Two entries reading one recording (a video, or a folder with one file prefix) would be one
    view counted as two cameras: refused."""
    seen: dict = {}
    for k, entry in enumerate(entries, start=1):
        kind = next(key for key in ("masks", "images", "video") if key in entry)
        key = (resolve(root, entry[kind], kind, doc_path).resolve(), entry.get("prefix"))
        require(key not in seen, f"camera {k} reads the {kind} {entry[kind]!r} of camera {seen.get(key)}: "
                "each camera needs its own recording", doc_path)
        seen[key] = k


def _pair_cameras(cams: list[Camera], entries: list[dict], calib: Path) -> list[Camera]:
    """Cameras in the order of the entries: by ``name`` when every entry has one, else by order."""
    names = [e.get("name") for e in entries if isinstance(e, dict)]
    if len(names) == len(entries) and all(isinstance(n, str) for n in names):
        by_name = {c.name: c for c in distinct_names(cams, calib)}
        missing = [n for n in names if n not in by_name]
        require(not missing, f"camera(s) {', '.join(missing)} not in the calibration (it has "
                f"{', '.join(by_name)})", calib)
        twice = sorted({n for n in names if names.count(n) > 1})
        require(not twice, f"dataset.json names camera(s) {', '.join(twice)} more than once (each "
                "entry is one camera of the calibration)", calib)
        return [by_name[n] for n in names]
    require(len(cams) == len(entries), f"the calibration has {len(cams)} cameras but dataset.json "
            f"lists {len(entries)} (give each camera entry the 'name' it has in the calibration)",
            calib)
    return list(cams)


def _fit_to_frames(cam: Camera, size: tuple[int, int], where: str, calib: Path,
                   crop=None, doc_path: Path | None = None) -> Camera:
    """The camera for frames of ``size``: the same, scaled (same aspect ratio) or cropped.

    Frames up to :data:`ipf_jax.cropping.AUTO_CROP` narrower or shorter than the calibrated
    image are that image cut at the right/bottom edge (principal point unchanged), with a
    warning; a ``crop`` entry names other edges (see :mod:`ipf_jax.cropping`).
    """
    from .cropping import crop_camera

    w, h = size
    if crop is None and (cam.width, cam.height) == (w, h):
        return cam
    if crop is None:
        scaled = cam.scaled(w / cam.width)
        if (scaled.width, scaled.height) == (w, h):
            return scaled
    return crop_camera(cam, w, h, crop, where=where, calib=calib, doc_path=doc_path)


def build_sources(path: Path, doc: dict) -> tuple[list[Camera], list]:
    """Cameras (full resolution) and one source per camera from a parsed ``dataset.json``.

    path : the dataset folder (relative paths in the file are relative to it).
    Returns (cameras, sources); raises :class:`IPFError` naming the file and the problem.
    """
    path = Path(path)
    doc_path = path / "dataset.json"
    bad = sorted(set(doc) - _TOP_KEYS)
    require(not bad, f"unknown key(s) {', '.join(bad)} (known: {', '.join(sorted(_TOP_KEYS))})",
            doc_path)
    version = doc.get("version", 1)
    require(version == 1 and not isinstance(version, bool), f"'version' {version!r}: this ipf-jax "
            "reads dataset.json version 1 (a newer file needs a newer ipf-jax)", doc_path)
    require("calibration" in doc, "dataset.json needs a 'calibration' file", doc_path)
    up = doc.get("up_axis")
    require(up is None or up in AXES, f"'up_axis' must be one of {', '.join(AXES)}, got {up!r}",
            doc_path)
    seg_defaults = doc.get("segmentation") or {}
    require(isinstance(seg_defaults, dict), "'segmentation' must be an object", doc_path)
    entries = doc["cameras"]
    sources, segs = [], []
    for k, entry in enumerate(entries, start=1):
        src, seg = make_source(entry, path, f"camera {k}", doc_path, seg_defaults)
        sources.append(src)
        segs.append(seg)
    calib = resolve(path, doc["calibration"], "'calibration'", doc_path)
    units = doc.get("calibration_units")
    w, h = sources[0].size
    cams = _pair_cameras(read_calibration(calib, w, h, units=units), entries, calib)
    _one_recording_each(entries, path, doc_path)
    crops = [e.get("crop", doc.get("crop")) for e in entries]
    cams = [_fit_to_frames(c, s.size, f"camera {k}", calib, crop, doc_path)
            for k, (c, s, crop) in enumerate(zip(cams, sources, crops), start=1)]
    for k, (entry, src) in enumerate(zip(entries, sources), start=1):
        if "roi" in entry:  # in pixels of the frames, known only now
            roi = roi_mask(entry["roi"], *src.size, f"camera {k}", doc_path)
            src.seg = src.seg._replace(roi=roi)
    if "frames" in doc:
        sl = parse_frames(doc["frames"], "'frames'", doc_path)
        for k, src in enumerate(sources, start=1):
            src.frames = select_frames(src.frames, sl, where=f"'frames' (camera {k})",
                                       path=doc_path)
    cams = _place_cameras(cams, sources, entries, doc, doc_path)
    return cams, sources


def _place_cameras(cams, sources, entries, doc, doc_path) -> list[Camera]:
    """Apply ``camera_height`` (metres, or ``"from_person"`` with ``height_m``) per camera."""
    from ..geometry.placement import camera_at_height, camera_height_from_person

    wanted = [e.get("camera_height", doc.get("camera_height")) for e in entries]
    if all(v is None for v in wanted):
        return cams
    height_m = doc.get("height_m")
    up_axis = doc.get("up_axis")
    out = []
    for k, (cam, src, value) in enumerate(zip(cams, sources, wanted), start=1):
        if value is None:
            out.append(cam)
            continue
        sample = [src.frames[int(i)] for i in
                  np.unique(np.linspace(0, len(src.frames) - 1, PERSON_FRAMES).round())]
        if up_axis is None:
            up_axis = detect_up_axis([cam], [src.mask(sample[len(sample) // 2])])
        up = axis_vector(up_axis)
        if value == "from_person":
            require(height_m is not None, f"camera {k}: camera_height \"from_person\" needs "
                    "'height_m', the person's height in metres", doc_path)
            h = _number(height_m, "'height_m'", doc_path, lo=0.5, hi=2.6)
            value, _ = camera_height_from_person(cam, [src.mask(f) for f in sample], up, h,
                                                 where=str(doc_path))
        value = _number(value, f"camera {k} camera_height (metres or \"from_person\")", doc_path,
                        lo=0.05, hi=1000.0)
        out.append(camera_at_height(cam, up, value))
    return out
