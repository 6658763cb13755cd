"""Datasets: calibrated cameras + a per-frame source of foreground masks.

Layouts (detected from the folder):

* **bodytrack**: ``CALIB/CameraK.cal`` (or ``CALIB/cameras.json``), masks ``FGk/imageNNNN.bmp|png``,
  optional grey images ``CAMk/imageNNNN.bmp``. Frame numbers come from the file names and must be
  the same for every camera.
* **ipf-jax** (``dataset.json``): any calibration file the readers know, and per camera either a
  mask folder, an image folder with a background image, or a video with an optional background
  video (else the temporal median of the video). See docs/formats.md.

A dataset exposes ``cameras`` (full resolution), ``frames`` (frame numbers), ``fps`` (or None),
``masks(frame) -> list of (H_c, W_c) bool`` and ``images(frame)`` (for overlays; may be None).
"""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from ..errors import IPFError, load_json, require
from ..geometry.camera import Camera
from .calibration import read_bodytrack_cal, read_json
from .sources import MaskSource

_IMAGE_EXT = {".bmp", ".png", ".jpg", ".jpeg", ".tif", ".tiff"}
_VIDEO_EXT = {".avi", ".mp4", ".mov", ".mkv", ".m4v", ".mpg", ".mpeg", ".webm", ".wmv"}
INIT_HINT = ("'ipf-jax init-dataset VIDEO_OR_FOLDER ... --calibration FILE --out DIR' "
             "(see docs/formats.md)")


def _natural_key(p: Path):
    return [int(t) if t.isdigit() else t for t in re.split(r"(\d+)", p.name)]


class Dataset:
    """Cameras and their mask sources (one per camera, same frames)."""

    def __init__(self, path: Path, cameras: list[Camera], sources: list, *, fps: float | None = None,
                 up_axis: str | None = None, layout: str = ""):
        self.path = Path(path)
        self.cameras = cameras
        self.sources = sources
        self.fps = fps
        self.up_axis = up_axis
        self.layout = layout
        require(len(cameras) == len(sources),
                f"{len(cameras)} cameras in the calibration but {len(sources)} mask sources", self.path)
        frame_sets = [s.frames for s in sources]
        for k, fr in enumerate(frame_sets[1:], start=2):
            if fr != frame_sets[0]:
                only = sorted(set(frame_sets[0]) ^ set(fr))
                src = sources[k - 1]
                raise IPFError(f"camera {k} has {len(fr)} frames, camera 1 has {len(frame_sets[0])}: "
                               "frame numbers must be the same for every camera (in one camera only: "
                               f"{', '.join(map(str, only[:5]))}{' ...' if len(only) > 5 else ''})",
                               getattr(src, "folder", None) or getattr(src, "path", None) or self.path)
        self.frames = list(frame_sets[0])

    @property
    def name(self) -> str:
        return self.path.name

    def masks(self, frame: int) -> list[np.ndarray]:
        out = []
        for k, (src, cam) in enumerate(zip(self.sources, self.cameras), start=1):
            m = src.mask(frame)
            if m.shape != (cam.height, cam.width):
                where = src.file(frame) if hasattr(src, "file") else self.path
                raise IPFError(f"mask of camera {k} is {m.shape[1]}x{m.shape[0]} but its calibration "
                               f"says {cam.width}x{cam.height}", where)
            out.append(m)
        return out

    def images(self, frame: int) -> list[np.ndarray] | None:
        """Camera images for overlays, (H, W, 3) uint8 BGR, when every camera has them; else None."""
        out = [s.image(frame) for s in self.sources]
        return None if not out or any(im is None for im in out) else out


def _check_principal_point(cam: Camera, path: Path) -> None:
    cx, cy = cam.K[0, 2], cam.K[1, 2]
    if not (0 <= cx < cam.width and 0 <= cy < cam.height):
        raise IPFError(f"principal point ({cx:.1f}, {cy:.1f}) lies outside the {cam.width}x{cam.height} "
                       "masks: masks and calibration do not belong together", path)


def open_bodytrack(path: Path) -> Dataset:
    calib = path / "CALIB"
    fg = sorted([p for p in path.glob("FG*") if p.is_dir() and p.name[2:].isdigit()], key=_natural_key)
    require(bool(fg), "no FG1.. mask folders", path)
    images = [path / f"CAM{f.name[2:]}" for f in fg]
    have_images = all(p.is_dir() for p in images)
    sources = [MaskSource(f, prefix=None, images=im if have_images else None)
               for f, im in zip(fg, images)]
    first = [s.mask(s.frames[0]) for s in sources]
    if (calib / "cameras.json").exists():
        cams = read_json(calib / "cameras.json")
    else:
        cal_files = sorted(calib.glob("Camera*.cal"), key=_natural_key)
        require(bool(cal_files), "no CALIB/CameraK.cal files", calib)
        # .cal files hold no image size: it comes from the masks, so a camera whose masks have
        # another size would silently get intrinsics made for the others' size
        for f, m in zip(fg[1:], first[1:]):
            require(m.shape == first[0].shape, f"masks are {m.shape[1]}x{m.shape[0]} but {fg[0].name}'s "
                    f"are {first[0].shape[1]}x{first[0].shape[0]}: with .cal calibrations (no image "
                    "size in them) every camera's masks must have the same size (CALIB/cameras.json gives "
                    "each camera its own)", f)
        cams = []
        for f, m in zip(cal_files, first):
            cams.append(read_bodytrack_cal(f, width=m.shape[1], height=m.shape[0]))
        require(len(cal_files) == len(fg),
                f"{len(cal_files)} calibration files but {len(fg)} FG folders", calib)
    for cam, f in zip(cams, fg):
        _check_principal_point(cam, f)
    return Dataset(path, cams, sources, layout="bodytrack")


MAX_FPS = 10000  # as --fps: beyond, 6-decimal time_s values no longer increase


def open_dataset(path: str | Path) -> Dataset:
    """Open a dataset folder (layout detected); raises IPFError with the folder and the problem."""
    path = Path(path)
    if not path.exists():
        raise IPFError("dataset folder not found", path)
    if not path.is_dir():
        kind = "a video file" if path.suffix.lower() in _VIDEO_EXT else \
            "an image file" if path.suffix.lower() in _IMAGE_EXT \
            else "a file"
        raise IPFError(f"dataset must be a folder, and this is {kind}: describe your videos or "
                       f"image folders and their calibration with {INIT_HINT}", path)
    if (path / "dataset.json").exists():
        return open_described(path)
    if (path / "CALIB").is_dir():
        return open_bodytrack(path)
    images = [p for p in path.iterdir() if p.suffix.lower() in _IMAGE_EXT]
    videos = [p for p in path.iterdir() if p.suffix.lower() in _VIDEO_EXT]
    found = (f" (it holds {len(images)} images)" if images else
             f" (it holds {len(videos)} videos)" if videos else "")
    raise IPFError(f"unknown dataset layout{found}: expected CALIB/ + FGk/ folders (bodytrack) or "
                   f"a dataset.json; write one with {INIT_HINT}", path)


def open_described(path: Path) -> Dataset:
    """The ipf-jax layout: ``dataset.json`` (see docs/formats.md)."""
    from .sources import build_sources

    doc_path = path / "dataset.json"
    doc = load_json(doc_path, "dataset.json")
    require(isinstance(doc, dict) and isinstance(doc.get("cameras"), list) and doc["cameras"],
            "dataset.json needs a non-empty 'cameras' list", doc_path)
    cams, sources = build_sources(path, doc)
    for cam in cams:
        _check_principal_point(cam, doc_path)
    fps = doc.get("fps")
    require(fps is None or (isinstance(fps, (int, float)) and not isinstance(fps, bool)
                            and np.isfinite(fps) and 0 < fps <= MAX_FPS),
            f"'fps' must be a positive number up to {MAX_FPS} Hz (time_s keeps 6 decimals), "
            f"got {fps!r}", doc_path)
    if fps is None:  # the videos' own rate; an impossible one (a stream's 90 kHz clock) is unknown
        fps = next((s.fps for s in sources if getattr(s, "fps", None) and 0 < s.fps <= MAX_FPS), None)
    height = doc.get("height_m")
    require(height is None or (isinstance(height, (int, float)) and not isinstance(height, bool)
                               and np.isfinite(height) and 0.5 <= height <= 2.6),
            f"'height_m' must be a standing height in metres, 0.5..2.6, got {height!r}", doc_path)
    ds = Dataset(path, cams, sources, fps=float(fps) if fps else None, up_axis=doc.get("up_axis"),
                 layout="ipf-jax")
    ds.height_m = height  # the subject's height when the file gives it (or None)
    return ds


class MemoryDataset(Dataset):
    """Masks already in memory (T, C, H, W) bool: the demo and tests."""

    def __init__(self, cameras: list[Camera], masks: np.ndarray, *, frames=None, fps=None,
                 name: str = "memory", up_axis: str | None = None):
        self.path = Path(name)
        self.cameras = cameras
        self._masks = masks
        self.frames = list(frames if frames is not None else range(len(masks)))
        self.fps = fps
        self.up_axis = up_axis
        self.layout = "memory"
        self.sources = []  # no files: no camera images either
        self._index = {f: i for i, f in enumerate(self.frames)}

    def masks(self, frame: int) -> list[np.ndarray]:
        i = self._index[frame]
        return [self._masks[i, c, : cam.height, : cam.width] for c, cam in enumerate(self.cameras)]


def pick_cameras(cameras, text: str | None, option: str = "cameras") -> list[int]:
    """Indices of the cameras named in ``text`` (comma-separated names or 1-based numbers);
    ``option`` names the setting in the error."""
    if not text:
        return list(range(len(cameras)))
    names = [c.name for c in cameras]
    out = []
    for item in (t.strip() for t in text.split(",") if t.strip()):
        if item in names:
            out.append(names.index(item))
        elif item.isdigit() and 1 <= int(item) <= len(cameras):
            out.append(int(item) - 1)
        else:
            raise IPFError(f"{option}: no camera {item!r} (cameras: {', '.join(names)}, or 1.."
                           f"{len(cameras)})")
    require(bool(out), f"{option} {text!r} names no camera (cameras: {', '.join(names)}, or 1.."
            f"{len(cameras)})")
    return out
