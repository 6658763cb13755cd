"""Silhouettes: reading masks and camera images, resizing masks, background subtraction.

Image readers check the file before OpenCV sees it (missing, empty, truncated BMP/PNG/JPEG) because
some OpenCV versions decode a truncated file into a partly grey image without complaint, and
raise :class:`ipf_jax.errors.IPFError` naming the file. Masks are ``(H, W)`` bool, non-zero =
foreground; colour images are ``(H, W, 3)`` uint8 in OpenCV's BGR order.

Background subtraction is the paper's segmentation (a pixel is foreground when it differs from a
static background image by more than a threshold); the morphological clean-up after it is ours.
"""
from __future__ import annotations

import struct
from pathlib import Path

import cv2
import numpy as np

from ..errors import IPFError, require

THRESHOLD = 30  # 8-bit grey levels: above sensor noise and compression artefacts, below most
# person/background contrasts (uu room: person+chair 10-13k px at 20-40, stable)
OPEN_PX = 3  # opening removes specks thinner than this (noise, compression blocks)
CLOSE_PX = 7  # closing fills holes and cracks narrower than this (clothes like the background)


# --- reading -------------------------------------------------------------------------------------

def _read_bytes(path: Path) -> bytes:
    if not path.exists():
        raise IPFError("image file not found", path)
    require(path.is_file(), "is a folder, not an image file", path)
    try:
        data = path.read_bytes()
    except OSError as e:
        raise IPFError(f"cannot read image file ({e})", path) from None
    require(len(data) > 0, "empty (zero-byte) image file", path)
    return data


def _bmp_needed(data: bytes) -> int:
    """Bytes a BMP needs according to its header (header size when the header itself is cut)."""
    if len(data) < 26:
        return 26
    offset, dib = struct.unpack_from("<II", data, 10)
    if dib == 12:  # OS/2 BITMAPCOREHEADER
        w, h, _, bpp = struct.unpack_from("<HHHH", data, 18)
        compression = 0
    else:
        if len(data) < 34:
            return 34
        w, h, _, bpp, compression = struct.unpack_from("<iiHHI", data, 18)
    if compression in (0, 3, 6):  # uncompressed rows (RGB, BITFIELDS, ALPHABITFIELDS)
        stride = (abs(w) * bpp + 31) // 32 * 4
        return offset + stride * abs(h)
    return struct.unpack_from("<I", data, 2)[0]  # RLE/embedded: only the declared file size


def _png_complete(data: bytes) -> bool:
    """Every chunk fits in the file and the IEND chunk is there."""
    pos = 8
    while pos + 8 <= len(data):
        length, kind = struct.unpack_from(">I4s", data, pos)
        pos += 12 + length  # length, type, data, CRC
        if pos > len(data):
            return False
        if kind == b"IEND":
            return True
    return False


MAX_SIDE = 32768  # pixels: larger images are refused before decoding (a corrupt header could
MAX_PIXELS = 1 << 27  # otherwise make OpenCV allocate gigabytes); 8K video is 2**25 pixels


def _declared_size(data: bytes) -> tuple[int, int] | None:
    """(width, height) that a PNG, BMP or JPEG header declares, or None (other formats, or cut)."""
    if data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) >= 24:
        return struct.unpack_from(">II", data, 16)
    if data[:2] == b"BM" and len(data) >= 26:
        dib = struct.unpack_from("<I", data, 14)[0]
        if dib == 12:
            return struct.unpack_from("<HH", data, 18)
        if len(data) >= 26:
            w, h = struct.unpack_from("<ii", data, 18)
            return abs(w), abs(h)
    if data[:3] == b"\xff\xd8\xff":
        pos = 2
        while pos + 9 <= len(data) and data[pos] == 0xFF:
            marker, length = data[pos + 1], struct.unpack_from(">H", data, pos + 2)[0]
            if 0xC0 <= marker <= 0xCF and marker not in (0xC4, 0xC8, 0xCC):  # start of frame
                h, w = struct.unpack_from(">HH", data, pos + 5)
                return w, h
            pos += 2 + length
    return None


def _check_complete(data: bytes, path: Path) -> None:
    size = _declared_size(data)
    if size is not None:
        w, h = size
        require(0 < w <= MAX_SIDE and 0 < h <= MAX_SIDE and w * h <= MAX_PIXELS,
                f"image header declares {w}x{h} pixels: not a usable image (corrupt header?)", path)
    if data[:2] == b"BM":
        need = _bmp_needed(data)
        require(len(data) >= need,
                f"truncated image: {len(data)} bytes, its BMP header needs {need}", path)
    elif data[:8] == b"\x89PNG\r\n\x1a\n":
        require(_png_complete(data), "truncated image: PNG chunks cut short or no IEND chunk", path)
    elif data[:3] == b"\xff\xd8\xff":
        sos = data.rfind(b"\xff\xda")
        require(sos >= 0 and data.find(b"\xff\xd9", sos) >= 0,
                "truncated image: JPEG has no end-of-image marker after its scan data", path)


def _decode(path: str | Path, flags: int) -> np.ndarray:
    path = Path(path)
    data = _read_bytes(path)
    _check_complete(data, path)
    image = cv2.imdecode(np.frombuffer(data, np.uint8), flags)
    require(image is not None and image.size > 0,
            "corrupt or truncated image (OpenCV cannot decode it)", path)
    return image


def read_mask(path: str | Path) -> np.ndarray:
    """Silhouette mask from a PNG/BMP (any image OpenCV reads). Returns (H, W) bool.

    Non-zero = foreground; in a colour or RGBA image a pixel is foreground when any colour channel
    is non-zero (alpha is ignored: masks are often saved opaque).
    """
    image = _decode(path, cv2.IMREAD_UNCHANGED)
    # only float files (32-bit TIFF) can hold NaN: neither foreground nor background, so refused
    require(image.dtype.kind != "f" or not np.isnan(image).any(),
            f"mask has {int(np.isnan(image).sum()) if image.dtype.kind == 'f' else 0} NaN pixels "
            "(a float image): a mask must be 0 (background) or non-zero (foreground)", path)
    if image.ndim == 3:
        return np.any(image[..., :3] != 0, axis=2)
    return image != 0


def read_gray(path: str | Path) -> np.ndarray:
    """Camera image as (H, W) uint8 grey levels."""
    return _decode(path, cv2.IMREAD_GRAYSCALE)


def read_color(path: str | Path) -> np.ndarray:
    """Camera image as (H, W, 3) uint8, BGR (OpenCV order; grey files are replicated)."""
    return _decode(path, cv2.IMREAD_COLOR)


# --- masks ---------------------------------------------------------------------------------------

def resize_mask(mask: np.ndarray, height: int, width: int) -> np.ndarray:
    """Resize a (H, W) mask to (height, width) bool: area average, foreground where >= 0.5.

    Area averaging keeps the pixel-centre convention of :meth:`ipf_jax.geometry.camera.Camera.scaled`, so
    masks and scaled cameras stay aligned.
    """
    mask = np.asarray(mask)
    require(mask.ndim == 2, f"mask must be 2-D (H, W), got shape {mask.shape}")
    require(height > 0 and width > 0, f"target size must be positive, got {width}x{height}")
    if mask.shape == (height, width):
        return mask.astype(bool)
    frac = cv2.resize(mask.astype(np.float32), (int(width), int(height)),
                      interpolation=cv2.INTER_AREA)
    return frac >= 0.5


def _ellipse(px: int) -> np.ndarray:
    return cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (px, px))


def foreground(frame: np.ndarray, background: np.ndarray, threshold: float = THRESHOLD, *,
               open_px: int = OPEN_PX, close_px: int = CLOSE_PX,
               cover: float | None = None) -> np.ndarray:
    """Background subtraction: (H, W) bool foreground of ``frame`` against a static ``background``.

    frame, background : (H, W) or (H, W, C) images of the same shape and scale (uint8: grey levels).
    threshold : a pixel is foreground when ``|frame - background| > threshold``; for colour, the
        largest difference over the channels (so a change of hue alone counts).
    open_px, close_px : diameters of the elliptical kernels of the clean-up, an opening (drops
        specks) then a closing (fills small holes); 0 or 1 skips that step.
    cover : when given (e.g. 0.9), keep only the largest 8-connected components, biggest first,
        until they hold this fraction of the foreground pixels; the rest (scattered noise, small
        shadows) is dropped. ``None`` keeps everything (several people, a body cut in two by an
        occluder).

    Returns (H, W) bool.
    """
    frame, background = np.asarray(frame), np.asarray(background)
    require(frame.shape == background.shape,
            f"frame shape {frame.shape} differs from background shape {background.shape}")
    require(frame.ndim in (2, 3), f"images must be (H, W) or (H, W, C), got shape {frame.shape}")
    require(cover is None or 0.0 < cover <= 1.0, f"cover must be in (0, 1], got {cover}")
    if frame.dtype == np.uint8 and background.dtype == np.uint8:
        diff = cv2.absdiff(frame, background)  # saturating, no wrap-around
    else:
        diff = np.abs(frame.astype(np.float32) - background.astype(np.float32))
    if diff.ndim == 3:
        diff = diff.max(axis=2)
    fg = (diff > threshold).astype(np.uint8)
    if open_px > 1:
        fg = cv2.morphologyEx(fg, cv2.MORPH_OPEN, _ellipse(open_px))
    if close_px > 1:
        fg = cv2.morphologyEx(fg, cv2.MORPH_CLOSE, _ellipse(close_px))
    if cover is not None:
        fg = largest_components(fg.astype(bool), cover)
    return fg.astype(bool)


def largest_components(mask: np.ndarray, cover: float) -> np.ndarray:
    """Keep the largest 8-connected components of a (H, W) bool mask holding ``cover`` of it."""
    n, labels, stats, _ = cv2.connectedComponentsWithStats(mask.astype(np.uint8), connectivity=8)
    if n <= 2:
        return mask.astype(bool)
    areas = stats[1:, cv2.CC_STAT_AREA]
    order = np.argsort(-areas, kind="stable")
    needed = np.searchsorted(np.cumsum(areas[order]), cover * areas.sum()) + 1
    keep = np.zeros(n, bool)
    keep[order[:needed] + 1] = True
    return keep[labels]


# --- background ----------------------------------------------------------------------------------

def median_background(reader, k: int = 25, *, start: int = 0,
                      stop: int | None = None) -> np.ndarray:
    """Temporal median of ``k`` frames sampled evenly over ``[start, stop)`` of a clip.

    reader : a :class:`ipf_jax.data.video.VideoReader` or :class:`ipf_jax.data.video.ImageSequence` (anything
        with ``frame_count`` and ``frames(indices)`` yielding ``(index, image)``).
    Only the k sampled frames are held (one (k, H, W[, C]) array); the median is taken a band of
    rows at a time so its float temporaries stay small. With a person who keeps moving, each pixel
    shows the background in most samples and the median recovers it; a person who stays put ends
    up in the background.

    Returns (H, W[, C]) image of the frames' dtype (integers rounded; k odd gives an exact frame
    value).
    """
    stop = reader.frame_count if stop is None else stop
    require(0 <= start < stop <= reader.frame_count,
            f"frame range [{start}, {stop}) is outside the clip's {reader.frame_count} frames")
    require(k >= 1, f"k must be at least 1, got {k}")
    indices = np.unique(np.linspace(start, stop - 1, min(k, stop - start)).round().astype(int))
    stack = None
    for j, (_, image) in enumerate(reader.frames(indices)):
        if stack is None:
            stack = np.empty((len(indices),) + image.shape, image.dtype)
        require(image.shape == stack.shape[1:],
                f"frame shape {image.shape} differs from the first frame's {stack.shape[1:]}")
        stack[j] = image
    out = np.empty(stack.shape[1:], stack.dtype)
    row_values = len(indices) * int(np.prod(stack.shape[2:]))
    band = max(1, (1 << 20) // row_values)  # ~1M samples per band: temporaries of a few MB
    for r0 in range(0, out.shape[0], band):
        med = np.median(stack[:, r0:r0 + band], axis=0)
        out[r0:r0 + band] = np.rint(med) if np.issubdtype(out.dtype, np.integer) else med
    return out
