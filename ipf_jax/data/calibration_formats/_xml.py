"""Safe XML loading and attribute parsing shared by the lab-format readers.

A calibration is a few kilobytes: a file above :data:`MAX_BYTES` is refused before parsing, and a
document type declaration (the door to entity expansion) is refused outright. Every problem is an
:class:`ipf_jax.errors.IPFError` naming the file.
"""
from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from ...errors import IPFError, require
from ...geometry.camera import Camera, validate_camera

MAX_BYTES = 32 << 20  # 32 MB: a calibration of 1000 cameras is well under 1 MB


def read_bytes(path: Path, what: str = "calibration file") -> bytes:
    """The file's bytes; missing, unreadable or huge files are IPFErrors."""
    try:
        size = path.stat().st_size
    except FileNotFoundError:
        raise IPFError(f"{what} not found", path) from None
    except OSError as e:
        raise IPFError(f"cannot read {what} ({e.strerror or e})", path) from None
    require(path.is_file(), f"{what} is a folder, not a file", path)
    require(size <= MAX_BYTES, f"{what} is {size / 2**20:.0f} MB: too large for a calibration "
            f"(at most {MAX_BYTES >> 20} MB)", path)
    try:
        return path.read_bytes()
    except OSError as e:
        raise IPFError(f"cannot read {what} ({e.strerror or e})", path) from None


def decode(data: bytes) -> str:
    """Text of an XML/text file: UTF-8 (with or without BOM) or UTF-16 (Motive writes UTF-16LE)."""
    if data.startswith((b"\xff\xfe", b"\xfe\xff")):
        return data.decode("utf-16", "replace")
    if len(data) >= 4 and data[1:2] == b"\x00" and data[3:4] == b"\x00":  # UTF-16LE without BOM
        return data.decode("utf-16-le", "replace")
    return data.decode("utf-8-sig", "replace")


def load_root(path: Path, what: str) -> ET.Element:
    """Root element of an XML calibration; ``what`` names the format in messages."""
    text = decode(read_bytes(path)).lstrip()
    require("<!DOCTYPE" not in text[:4096] and "<!ENTITY" not in text,
            f"not a readable {what} file (document type declarations are refused)", path)
    if text.startswith("<?xml"):  # the declared encoding no longer applies to decoded text
        end = text.find("?>")
        text = text[end + 2:] if end >= 0 else text
    try:
        return ET.fromstring(text)
    except ET.ParseError as e:
        raise IPFError(f"not a readable {what} file (XML error: {e})", path) from None


def number(el: ET.Element, attr: str, where: str, path: Path, default: float | None = None) -> float:
    """A finite number from attribute ``attr`` of ``el``."""
    value = el.get(attr)
    if value is None:
        require(default is not None, f"{where}: missing {attr}", path)
        return float(default)
    try:
        x = float(value)
    except ValueError:
        raise IPFError(f"{where}: {attr} is not a number ({value[:20]!r})", path) from None
    require(math.isfinite(x), f"{where}: {attr} is not finite ({value[:20]!r})", path)
    return x


def numbers(el: ET.Element, attr: str, where: str, path: Path, count: int | None = None,
            words: int = 0) -> list[float]:
    """Space-separated finite numbers of attribute ``attr``, after ``words`` leading words."""
    value = el.get(attr)
    require(value is not None, f"{where}: missing {attr}", path)
    parts = value.split()[words:]
    try:
        xs = [float(p) for p in parts]
    except ValueError:
        raise IPFError(f"{where}: {attr} holds non-numeric text ({value[:30]!r})", path) from None
    require(count is None or len(xs) == count,
            f"{where}: {attr} has {len(xs)} numbers, expected {count}", path)
    require(all(math.isfinite(x) for x in xs), f"{where}: {attr} holds non-finite numbers", path)
    return xs


def image_size(w: float, h: float, where: str, path: Path) -> tuple[int, int]:
    """A positive integer image size of at most 100k pixels a side."""
    require(0 < w <= 100_000 and 0 < h <= 100_000 and float(w).is_integer()
            and float(h).is_integer(), f"{where}: image size {w:g}x{h:g} is not a positive "
            "whole number of pixels (at most 100000)", path)
    return int(w), int(h)


def write_text(path: Path, text: str, encoding: str = "utf-8") -> None:
    """Write a file whole (a temporary file renamed over it: never half-written)."""
    path = Path(path)
    tmp = path.with_name(path.name + ".tmp")
    try:
        tmp.write_bytes(text.encode(encoding))
        tmp.replace(path)
    except OSError as e:
        tmp.unlink(missing_ok=True)
        raise IPFError(f"cannot write ({e.strerror or e})", path) from None


def pinhole_camera(fx: float, fy: float, cx: float, cy: float, dist, R: np.ndarray,
                   centre: np.ndarray, width: int, height: int, name: str, path: Path) -> Camera:
    """A validated :class:`Camera` (no skew) from focal lengths and principal point (px), OpenCV
    distortion (k1, k2, p1, p2, k3), world-to-camera rotation ``R`` and the camera centre (m)."""
    cam = Camera(K=np.array([[fx, 0.0, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]]), dist=np.asarray(dist, float),
                 R=R, T=-R @ centre, width=width, height=height, name=name, source=str(path))
    return validate_camera(cam, str(path))
