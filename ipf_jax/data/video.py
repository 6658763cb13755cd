"""Frame sources: a video file (:class:`VideoReader`) or a folder of numbered images
(:class:`ImageSequence`), with one interface.

Both expose ``frame_count``, ``fps`` (``None`` when unknown), ``width``, ``height``,
``frame_numbers`` (the dataset's number of each frame), ``read(i)`` for the i-th frame (0-based)
and ``frames(indices)`` yielding ``(i, image)``; both are context managers. Images are
(H, W, 3) uint8 BGR unless an ImageSequence is asked for grey levels or masks. Problems with the
input raise :class:`ipf_jax.errors.IPFError` naming the file; a video that decodes fewer frames
than it declares is an :class:`ipf_jax.errors.IPFWarning`. FFmpeg's own log lines ("[mjpeg @
0x..] overread 8") are silenced unless ``OPENCV_FFMPEG_LOGLEVEL`` is set: they name no file and
say what these messages say.
"""
from __future__ import annotations

import math
import os
import re
import warnings
from collections.abc import Iterable, Iterator
from pathlib import Path

import cv2
import numpy as np

from ..errors import IPFError, IPFWarning, require
from .silhouette import read_color, read_gray, read_mask

# read by OpenCV when its FFmpeg backend starts (the first VideoCapture); -8 is AV_LOG_QUIET
os.environ.setdefault("OPENCV_FFMPEG_LOGLEVEL", "-8")

#: a video decoding fewer than this share of the frames its container declares is said to be cut
#: (the Utrecht AVIs declare 428 and hold 426: containers' counts are often off by a frame or two)
DECLARED_SHARE = 0.99
MAX_SKIP = 250  # frames: decoding forward beats seeking below this gap (seeks decode from the
# previous keyframe, and encoders put keyframes up to 250 frames apart, x264's default)


class _FrameSource:
    """What both sources share: index checks, iteration, context management."""

    path: Path
    frame_count: int

    def read(self, i: int) -> np.ndarray:
        raise NotImplementedError

    def _check(self, i: int) -> int:
        i = int(i)
        if not 0 <= i < self.frame_count:
            raise IPFError(f"frame {i} out of range (0..{self.frame_count - 1})", self.path)
        return i

    def frames(self, indices: Iterable[int] | None = None) -> Iterator[tuple[int, np.ndarray]]:
        """Yield ``(i, image)`` for ``indices`` (a range or any sequence; default: every frame)."""
        for i in range(self.frame_count) if indices is None else indices:
            yield int(i), self.read(i)

    def __iter__(self) -> Iterator[tuple[int, np.ndarray]]:
        return self.frames()

    def __len__(self) -> int:
        return self.frame_count

    def close(self) -> None:
        pass

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.close()


class VideoReader(_FrameSource):
    """Frames of a video file through OpenCV's VideoCapture (FFmpeg).

    ``frame_count`` is the number of frames that actually decode. Containers often claim more
    (the Utrecht AVIs claim 428 and hold 426; a truncated file keeps its original count): the
    claim is kept as ``declared_frame_count`` and checked by decoding its last frame, which costs
    one seek; when that frame is missing, the frames are counted by decoding the whole file once
    (without colour conversion). ``read(i)`` seeks unless ``i`` is the next frame, and ``frames``
    decodes forward over gaps up to :data:`MAX_SKIP` frames instead of seeking.
    """

    def __init__(self, path: str | Path):
        self.path = Path(path)
        if not self.path.exists():
            raise IPFError("video file not found", self.path)
        require(self.path.is_file(), "is a folder, not a video file", self.path)
        require(self.path.stat().st_size > 0, "zero-length video (empty file)", self.path)
        self._cap = cv2.VideoCapture(str(self.path))
        if not self._cap.isOpened():
            raise IPFError("not a readable video (corrupt, truncated or unsupported format)",
                           self.path)
        ok, first = self._cap.read()
        if not ok:
            self.close()
            raise IPFError("zero-length video (no decodable frames)", self.path)
        self._pos: int | None = 1  # index of the frame the next cap.read() returns (None: unknown)
        self.height, self.width = first.shape[:2]
        fps = self._cap.get(cv2.CAP_PROP_FPS)
        self.fps = float(fps) if math.isfinite(fps) and fps > 0 else None
        self.declared_frame_count = int(self._cap.get(cv2.CAP_PROP_FRAME_COUNT))
        self.frame_count = self._count_frames(self.declared_frame_count)
        if self.frame_count < DECLARED_SHARE * self.declared_frame_count:
            warnings.warn(IPFWarning(f"{self.path}: only {self.frame_count} of the "
                                     f"{self.declared_frame_count} frames it declares decode "
                                     "(a cut or damaged file?)"), stacklevel=2)

    @property
    def frame_numbers(self) -> range:
        return range(self.frame_count)

    def _count_frames(self, declared: int) -> int:
        if declared > 1 and self._seek(declared - 1) and self._cap.grab():
            n = declared
            while self._cap.grab():  # more frames than declared
                n += 1
        else:
            self._cap.set(cv2.CAP_PROP_POS_FRAMES, 0)
            n = 0
            while self._cap.grab():
                n += 1
        self._pos = None  # wherever decoding stopped
        return max(n, 1)  # frame 0 decoded in __init__

    def _seek(self, i: int) -> bool:
        """Position so the next read returns frame i; False when the file has no frame i."""
        self._cap.set(cv2.CAP_PROP_POS_FRAMES, i)
        landed = int(self._cap.get(cv2.CAP_PROP_POS_FRAMES)) == i
        self._pos = i if landed else None
        return landed

    def read(self, i: int) -> np.ndarray:
        """Frame i (0-based) as (H, W, 3) uint8 BGR."""
        i = self._check(i)
        require(self._cap is not None, "video is closed", self.path)
        if self._pos != i and not self._seek(i):
            raise IPFError(f"cannot seek to frame {i} (corrupt or truncated video)", self.path)
        ok, frame = self._cap.read()
        if not ok:
            self._pos = None
            raise IPFError(f"cannot decode frame {i} (corrupt or truncated video)", self.path)
        self._pos = i + 1
        return frame

    def frames(self, indices: Iterable[int] | None = None) -> Iterator[tuple[int, np.ndarray]]:
        """Yield ``(i, frame)`` for ``indices`` (default: every frame), decoding forward over
        short gaps rather than seeking."""
        for i in range(self.frame_count) if indices is None else indices:
            i = self._check(i)
            if self._pos is not None and 0 < i - self._pos <= MAX_SKIP:
                while self._pos < i:
                    if not self._cap.grab():
                        raise IPFError(f"cannot decode frame {self._pos} (corrupt or truncated "
                                       "video)", self.path)
                    self._pos += 1
            yield i, self.read(i)

    def close(self) -> None:
        if getattr(self, "_cap", None) is not None:
            self._cap.release()
            self._cap = None
            self._pos = None


_READERS = {"color": read_color, "gray": read_gray, "mask": read_mask}
_IMAGE_EXT = r"\.(png|bmp|jpe?g|tiff?)"


class ImageSequence(_FrameSource):
    """A folder of numbered images, ``imageNNNN.png`` / ``.bmp`` / ``.jpg`` (bodytrack's layout).

    folder : the folder; prefix : the part of the file name before the number (``"image"``).
    mode : ``"color"`` (H, W, 3) uint8 BGR, ``"gray"`` (H, W) uint8 or ``"mask"`` (H, W) bool.
    fps : frames per second when known (image folders do not record it).

    Frames are ordered by number; ``frame_numbers[i]`` is the number in the i-th file name (gaps
    allowed). Every image must have the first one's size.
    """

    def __init__(self, folder: str | Path, prefix: str | None = "image", *, mode: str = "color",
                 fps: float | None = None):
        self.path = Path(folder)
        if not self.path.exists():
            raise IPFError("image folder not found", self.path)
        require(self.path.is_dir(), "not a folder", self.path)
        require(mode in _READERS, f"unknown mode {mode!r} (color, gray, mask)")
        if prefix is None:  # the name before the number that most images share ("image", "mask")
            names = [re.fullmatch(rf"(.*?)(\d+){_IMAGE_EXT}", f.name, re.IGNORECASE)
                     for f in self.path.iterdir()]
            prefixes = [m.group(1) for m in names if m]
            prefix = max(set(prefixes), key=prefixes.count) if prefixes else "image"
        pattern = re.compile(rf"{re.escape(prefix)}(\d+){_IMAGE_EXT}", re.IGNORECASE)
        numbered = {}
        for f in self.path.iterdir():
            m = pattern.fullmatch(f.name)
            if m:
                n = int(m.group(1))
                require(n not in numbered, f"two files for frame {n}: {numbered.get(n, f).name} "
                        f"and {f.name}", self.path)
                numbered[n] = f
        require(bool(numbered), f"no {prefix}NNNN.png/.bmp/.jpg images in folder", self.path)
        self.frame_numbers = sorted(numbered)
        self.files = [numbered[n] for n in self.frame_numbers]
        self.frame_count = len(self.files)
        self.fps = fps
        self._reader = _READERS[mode]
        self.height, self.width = self._reader(self.files[0]).shape[:2]

    def read(self, i: int) -> np.ndarray:
        """The i-th image (0-based, in frame-number order)."""
        f = self.files[self._check(i)]
        image = self._reader(f)
        require(image.shape[:2] == (self.height, self.width),
                f"image is {image.shape[1]}x{image.shape[0]}, the sequence's first is "
                f"{self.width}x{self.height}", f)
        return image
