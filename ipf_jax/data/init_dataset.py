"""``dataset.json`` from videos or image folders and a calibration, so nobody writes JSON by hand.

:func:`describe` pairs the inputs with the calibration's cameras (by the camera name appearing in
the file or folder name, e.g. QTM's ``Walk_Miqus_3_28526.avi`` for camera ``28526``; else by
order), checks the frame sizes (equal, same aspect ratio, or a sensor crop of at most 1 %) and
rates (videos within 0.5 % of each other), takes the frames every camera has, and fills in the
background and segmentation defaults. :func:`write` saves it (atomically, never over an existing
file unless asked). The format is docs/formats.md's.
"""
from __future__ import annotations

import json
import os
import re
import warnings
from pathlib import Path

from ..errors import IPFError, IPFWarning, require
from ..geometry.camera import Camera
from .calibration import distinct_names, read_calibration
from .dataset import MAX_FPS
from .silhouette import CLOSE_PX, OPEN_PX, THRESHOLD, read_color
from .video import ImageSequence, VideoReader

VIDEO_EXT = {".avi", ".mp4", ".mov", ".mkv", ".m4v", ".mpg", ".mpeg", ".webm", ".wmv"}
IMAGE_EXT = {".bmp", ".png", ".jpg", ".jpeg", ".tif", ".tiff"}
SEGMENTATION = {"threshold": THRESHOLD, "open_px": OPEN_PX, "close_px": CLOSE_PX, "cover": 0.95,
                "max_foreground": 0.5}  # cover: one person and small clutter dropped
RATE_TOLERANCE = 0.005


def _natural(p: Path):
    return [int(t) if t.isdigit() else t.lower() for t in re.split(r"(\d+)", p.name)]


def _numbered_prefix(folder: Path) -> str | None:
    """The prefix of the numbered images in a folder (``image`` for imageNNNN.png), or None."""
    counts: dict[str, int] = {}
    for f in folder.iterdir():
        m = re.fullmatch(r"(.*?)(\d+)\.(png|bmp|jpe?g|tiff?)", f.name, re.IGNORECASE)
        if m:
            counts[m.group(1)] = counts.get(m.group(1), 0) + 1
    return max(counts, key=counts.get) if counts else None


def expand_inputs(inputs: list[Path]) -> list[Path]:
    """One folder holding videos (or image sub-folders) stands for them, in natural order."""
    if len(inputs) == 1 and inputs[0].is_dir() and _numbered_prefix(inputs[0]) is None:
        folder = inputs[0]
        videos = sorted((p for p in folder.iterdir() if p.suffix.lower() in VIDEO_EXT), key=_natural)
        subs = sorted((p for p in folder.iterdir() if p.is_dir() and _numbered_prefix(p)),
                      key=_natural)
        require(bool(videos or subs), "no videos and no folders of numbered images in this folder",
                folder)
        return videos or subs
    return inputs


def _open(path: Path, masks: bool):
    """(reader, kind, prefix) for one input: a video file or a folder of numbered images."""
    if not path.exists():
        raise IPFError("input not found", path)
    if path.is_dir():
        prefix = _numbered_prefix(path)
        require(prefix is not None, "no numbered images (e.g. image0001.png) in this folder", path)
        mode = "mask" if masks else "color"
        return ImageSequence(path, prefix, mode=mode), ("masks" if masks else "images"), prefix
    require(not masks, "--masks needs folders of numbered mask images, not a file", path)
    if path.suffix.lower() in IMAGE_EXT:
        raise IPFError("a single image is not a recording: give the folder of numbered images",
                       path)
    return VideoReader(path), "video", None


def _background_size(path: Path) -> tuple[int, int]:
    """(width, height) of a --background: an image, or a video or image folder as an input."""
    if not path.exists():
        raise IPFError("background not found", path)
    if path.suffix.lower() in IMAGE_EXT and not path.is_dir():
        h, w = read_color(path).shape[:2]
        return w, h
    reader = _open(path, masks=False)[0]
    try:
        return reader.width, reader.height
    finally:
        reader.close()


def match_cameras(cams: list[Camera], inputs: list[Path], names: list[str] | None = None):
    """The camera of each input: by ``names``, else by the name in the file name, else by order."""
    by_name = {c.name: c for c in cams}
    if names:
        require(len(names) == len(inputs), f"{len(names)} --names for {len(inputs)} inputs")
        by_name = {c.name: c for c in distinct_names(cams, None)}
        missing = [n for n in names if n not in by_name]
        require(not missing, f"camera(s) {', '.join(missing)} not in the calibration (it has "
                f"{', '.join(by_name)})")
        return [by_name[n] for n in names], "given names"

    def found(p: Path) -> list[str]:
        for part in (p.name, p.parent.name):  # cam3/video.avi names its camera by its folder
            hit = [n for n in by_name if re.search(
                rf"(?<![0-9a-z]){re.escape(n.lower())}(?![0-9a-z])", part.lower())]
            if hit:
                return hit
        return []

    hits = [sorted(found(p), key=len, reverse=True) for p in inputs]
    chosen = [h[0] if h else None for h in hits]
    if all(chosen) and len(set(chosen)) == len(chosen):
        return [by_name[n] for n in chosen], "camera names in the file names"
    require(len(cams) == len(inputs), f"the calibration has {len(cams)} cameras "
            f"({', '.join(by_name)}) but {len(inputs)} inputs were given, and the file names do "
            "not name the cameras: give --names in input order")
    return list(cams), "order"


def describe(inputs: list[Path], calibration: Path, out: Path, *, names: list[str] | None = None,
             units: str | None = None, masks: bool = False, backgrounds: list[Path] | None = None,
             fps: float | None = None, up_axis: str | None = None) -> tuple[dict, list[str]]:
    """The dataset.json document and the lines of a summary (see module doc)."""
    inputs = expand_inputs([Path(p) for p in inputs])
    seen = [p.resolve() for p in inputs]
    twice = next((p for k, p in enumerate(inputs) if seen[k] in seen[:k]), None)
    require(twice is None, "given for two cameras: each camera needs its own recording", twice)
    require(not (masks and backgrounds), "--background applies to camera images or videos: masks "
            "need none (drop --background or --masks)")
    opened = [_open(p, masks) for p in inputs]
    readers = [r for r, _, _ in opened]
    w0, h0 = readers[0].width, readers[0].height
    cams = read_calibration(calibration, w0, h0, units=units)
    chosen, how = match_cameras(cams, inputs, names)
    notes = [f"{len(inputs)} camera(s), matched by {how}"]
    from .sources import _fit_to_frames

    for k, (cam, r, p) in enumerate(zip(chosen, readers, inputs), start=1):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            _fit_to_frames(cam, (r.width, r.height), f"camera {k} ({p.name})", calibration)
        size = f"{r.width}x{r.height}" + ("" if (r.width, r.height) == (cam.width, cam.height)
                                           else f" (calibrated {cam.width}x{cam.height})")
        notes.append(f"camera {k}: {p.name} -> {cam.name}, {size}, {r.frame_count} frames"
                     + (f", {r.fps:g} fps" if r.fps else ""))
        notes += [f"  note: {w.message}" for w in caught]
    rates = [r.fps for r in readers if r.fps and r.fps <= MAX_FPS]
    notes += [f"  note: {p.name}: its header's {r.fps:g} fps is not a frame rate; taken as unknown "
              "(give --fps)" for p, r in zip(inputs, readers) if r.fps and r.fps > MAX_FPS]
    if rates:
        lo, hi = min(rates), max(rates)
        require(hi - lo <= RATE_TOLERANCE * hi, f"the videos run at different rates ({lo:g} to "
                f"{hi:g} fps): they must be synchronised recordings at one rate")
    frame_sets = [list(r.frame_numbers) for r in readers]
    common = sorted(set(frame_sets[0]).intersection(*frame_sets[1:]))
    require(bool(common), "the inputs share no frame number")
    doc = {"format": "ipf-jax-dataset", "version": 1,
           "description": "written by ipf-jax init-dataset",
           "calibration": _rel(Path(calibration), out)}
    if units:
        doc["calibration_units"] = units
    if fps or rates:
        doc["fps"] = float(fps or rates[0])
    if up_axis:
        doc["up_axis"] = up_axis
    if any(fr != common for fr in frame_sets):
        doc["frames"] = [common[0], common[-1] + 1]
        notes.append(f"frames {common[0]}..{common[-1]} (the ones every camera has)")
        require(common == list(range(common[0], common[-1] + 1)),
                "the cameras' frame numbers overlap with gaps: give each camera the same frames")
    if not masks:
        doc["segmentation"] = dict(SEGMENTATION)
    require(backgrounds is None or len(backgrounds) == len(inputs),
            f"{len(backgrounds or [])} --background for {len(inputs)} inputs")
    entries = []
    for k, ((r, kind, prefix), cam, p) in enumerate(zip(opened, chosen, inputs)):
        e = {"name": cam.name, kind: _rel(p, out)}
        if prefix not in (None, "image"):
            e["prefix"] = prefix
        if backgrounds:
            bw, bh = _background_size(Path(backgrounds[k]))
            require((bw, bh) == (r.width, r.height), f"background is {bw}x{bh}, the frames of "
                    f"{p.name} are {r.width}x{r.height}", Path(backgrounds[k]))
            e["background"] = _rel(Path(backgrounds[k]), out)
        entries.append(e)
        r.close()
    doc["cameras"] = entries
    return doc, notes


def _rel(p: Path, out: Path) -> str:
    """A path relative to the dataset folder when it is beside or inside it, else absolute."""
    p = Path(p).resolve()
    try:
        rel = Path(os.path.relpath(p, Path(out).resolve())).as_posix()
    except ValueError:  # another Windows drive
        return str(p)
    return str(p) if rel.startswith("../..") else rel  # far away: the absolute path reads better


def write(doc: dict, out: Path, *, force: bool = False) -> Path:
    """``out/dataset.json`` (folder created); refuses to replace one unless ``force``."""
    out = Path(out)
    target = out / "dataset.json"
    require(force or not target.exists(), "dataset.json exists already (use --force to replace "
            "it)", target)
    try:
        out.mkdir(parents=True, exist_ok=True)
        tmp = target.with_name("dataset.json.tmp")
        tmp.write_text(json.dumps(doc, indent=1) + "\n")
        tmp.replace(target)
    except OSError as e:
        raise IPFError(f"cannot write ({e.strerror or e})", target) from None
    return target


__all__ = ["describe", "write", "expand_inputs", "match_cameras", "SEGMENTATION", "IPFWarning"]
