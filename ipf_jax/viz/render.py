"""``ipf-jax render RUN_DIR --out FILE.mp4|FILE.png|DIR``: the fitted model over every frame.

Reads the run (poses.csv, run.json's shape, up axis, per-frame weights), reopens its dataset
(``run.json`` ``dataset``, or ``--dataset``) and draws each frame's pose over each camera's image
(silhouette outlined) or mask (likelihood pixel sets coloured), cameras side by side (see
:mod:`ipf_jax.viz.overlay`). Writes an MP4 (``mp4v``) or AVI (``MJPG``) video, one PNG for a single
frame, or a folder of ``frameNNNNN.png``.
"""
from __future__ import annotations

import warnings
from pathlib import Path

import cv2
import numpy as np
from tqdm import tqdm

from ..errors import IPFError, IPFWarning, require

VIDEO_CODECS = {".mp4": "mp4v", ".m4v": "mp4v", ".mov": "mp4v", ".avi": "MJPG"}
IMAGE_EXT = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff")  # one frame, by cv2.imwrite
#: media it does not write: such a name is a mistake, not a folder to fill with PNGs
OTHER_MEDIA = (".gif", ".webp", ".mkv", ".webm", ".wmv", ".flv", ".mpg", ".mpeg")
MIN_SIDE, MAX_SIDE = 480, 960  # default view size: the camera's, kept legible and not too large


def _pick_frames(frames: np.ndarray, text: str | None) -> np.ndarray:
    from ..data.frames import parse_frames, select_frames

    if not text:
        return frames
    return np.array(select_frames(frames.tolist(), parse_frames(text)))


def _dataset_path(dataset, meta: dict, run_dir: Path) -> Path:
    if dataset:
        return Path(dataset)
    name = meta.get("dataset")
    require(isinstance(name, str) and name != "", "run.json names no dataset: give --dataset",
            run_dir / "run.json")
    path = Path(name)
    require(path.exists(), f"the run's dataset {name} is not found from here: give --dataset",
            run_dir / "run.json")
    return path


def _check_cameras(tracked, drawn: list[str], path: Path) -> None:
    """A dataset none of whose drawn cameras the run was tracked with is another recording (an
    error); drawing some cameras the run did not use is allowed (a held-out view) but said."""
    if not isinstance(tracked, list) or not tracked:
        return  # an older run.json: nothing to compare
    require(bool(set(drawn) & set(map(str, tracked))), f"none of the cameras drawn "
            f"({', '.join(drawn)}) is one the run was tracked with ({', '.join(map(str, tracked))}): "
            "is it the run's dataset?", path)
    others = [n for n in drawn if n not in tracked]
    if others:
        warnings.warn(IPFWarning(f"drawing camera(s) {', '.join(others)} the run was not tracked "
                                 "with (the model as their calibration places it)"))


class _Sink:
    """Where composed frames go: a video writer, one image, or a folder of PNGs."""

    def __init__(self, out: Path, fps: float, n_frames: int):
        self.out, self.fps = out, fps
        ext = out.suffix.lower()
        require(ext not in OTHER_MEDIA, f"cannot write {ext} files: give a {', '.join(VIDEO_CODECS)}, "
                f"{', '.join(IMAGE_EXT)} file or a folder", out)
        self.kind = "video" if ext in VIDEO_CODECS else "image" if ext in IMAGE_EXT else "folder"
        if self.kind == "image":
            require(n_frames == 1, f"a {ext} output holds one frame, {n_frames} selected: use "
                    "--frames A, or a folder or video output", out)
        target = out if self.kind == "folder" else out.parent
        try:
            target.mkdir(parents=True, exist_ok=True)
        except OSError as e:
            raise IPFError(f"cannot create output folder ({e})", target) from None
        self.writer = None
        self.written = 0

    def write(self, frame: int, image: np.ndarray) -> None:
        if self.kind == "video":
            if self.writer is None:
                fourcc = cv2.VideoWriter_fourcc(*VIDEO_CODECS[self.out.suffix.lower()])
                self.writer = cv2.VideoWriter(str(self.out), fourcc, self.fps,
                                              (image.shape[1], image.shape[0]))
                require(self.writer.isOpened(), "OpenCV cannot write this video (codec or path)",
                        self.out)
            self.writer.write(image)
        else:
            path = self.out if self.kind == "image" else self.out / f"frame{frame:05d}.png"
            require(cv2.imwrite(str(path), image), "cannot write image", path)
        self.written += 1

    def close(self) -> None:
        if self.writer is not None:
            self.writer.release()


def render_run(run_dir: str | Path, out: str | Path, *, dataset: str | Path | None = None,
               cameras: str | None = None, background: str | None = None, frames: str | None = None,
               size: int | None = None, fps: float | None = None, progress: bool = True) -> dict:
    """Render a run (see module doc). ``background``: "images", "masks" or None (images when the
    dataset has them). Returns a summary: output, kind, frames written, size, mean weight."""
    from ..data.dataset import open_dataset, pick_cameras
    from ..data.rundir import read_run
    from ..geometry.world import up_rotation
    from .overlay import frame_overlay

    run_dir, out = Path(run_dir), Path(out)
    run = read_run(run_dir)
    require(run.poses is not None, "the run has no poses.csv (needed to draw the model)", run_dir)
    require(run.shape is not None, "run.json has no 'shape' (needed to draw the model)",
            run_dir / "run.json")
    ds = open_dataset(_dataset_path(dataset, run.meta, run_dir))
    chosen = _pick_frames(run.frames, frames)
    absent = sorted(set(chosen.tolist()) - set(ds.frames))
    require(not absent, f"frame(s) {absent[:5]} of the run are not in the dataset "
            f"({min(ds.frames)}..{max(ds.frames)}): is it the run's dataset?", ds.path)
    cams = pick_cameras(ds.cameras, cameras)
    _check_cameras(run.meta.get("cameras"), [ds.cameras[c].name for c in cams], ds.path)
    if background is None:
        background = "images" if ds.images(int(chosen[0])) is not None else "masks"
    require(background in ("images", "masks"), f"unknown background {background!r}")
    step = int(np.min(np.diff(run.frames))) if len(run.frames) > 1 else 1
    rate = fps or run.fps / step
    require(rate > 0, f"--fps must be > 0 (got {rate})")
    if size is None:
        size = int(np.clip(max(max(ds.cameras[c].width, ds.cameras[c].height) for c in cams),
                           MIN_SIDE, MAX_SIDE))
    require(32 <= size <= 4096, f"--size must be 32..4096 px (got {size})")
    listed = run.meta.get("per_frame", [])
    require(isinstance(listed, list), "run.json's per_frame is not a list of frames (a damaged file?)",
            Path(run_dir) / "run.json")
    per_frame = {r.get("frame"): r for r in listed if isinstance(r, dict)}
    U = up_rotation(run.up_axis)
    row_of = {int(f): i for i, f in enumerate(run.frames)}
    sink = _Sink(out, rate, len(chosen))
    weights = []
    try:
        for frame in tqdm(chosen.tolist(), desc=f"render {run_dir.name}", unit="frame",
                          disable=not progress):
            masks = ds.masks(frame)
            if background == "images":
                images = ds.images(frame)
                require(images is not None, f"the dataset has no camera image for frame {frame}: "
                        "use --masks", ds.path)
                bgs, outline = [images[c] for c in cams], [masks[c] for c in cams]
            else:
                bgs, outline = [masks[c] for c in cams], None
            rec = per_frame.get(frame, {})
            q = run.poses[row_of[frame]]
            status = None if np.all(np.isfinite(q)) else "missing"
            if rec.get("status") in ("init", "reinit"):
                status = rec["status"]
            w = rec.get("weight")
            if w is not None:
                weights.append(w)
            image = frame_overlay(bgs, [ds.cameras[c] for c in cams], q, run.shape, U, w, frame,
                                  masks=outline, long_side=size, status=status,
                                  legend=background == "masks", even=sink.kind == "video")
            sink.write(frame, image)
    finally:
        sink.close()
    return {"out": str(out), "kind": sink.kind, "frames": sink.written, "background": background,
            "cameras": [ds.cameras[c].name for c in cams], "view_long_side": size, "fps": rate,
            "mean_weight": float(np.mean(weights)) if weights else None}
