"""VideoReader (frame counts that lie, seeking, bad files) and ImageSequence."""
from __future__ import annotations

import os
import re
import warnings

import cv2
import numpy as np
import pytest

from ipf_jax.data.video import ImageSequence, VideoReader
from ipf_jax.errors import IPFError, IPFWarning


def decode_all(path):
    """Every frame by plain sequential decoding: the reference for counts and contents."""
    cap, frames = cv2.VideoCapture(str(path)), []
    while True:
        ok, frame = cap.read()
        if not ok:
            return frames
        frames.append(frame)


def write_video(path, n, size=(64, 48), fps=25.0, noise=False):
    """An MJPG clip of grey levels (i * 20) % 250, or of random pixels with ``noise``."""
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), fps, size)
    assert writer.isOpened()
    rng = np.random.default_rng(0)
    for i in range(n):
        frame = (rng.integers(0, 256, (size[1], size[0], 3), dtype=np.uint8) if noise
                 else np.full((size[1], size[0], 3), (i * 20) % 250, np.uint8))
        writer.write(frame)
    writer.release()
    return path


@pytest.fixture(scope="module")
def uu_video(shared_data):
    path = shared_data("uu_4cam_background") / "cam1" / "video.avi"
    return path, decode_all(path)


def test_uu_video_counts_decodable_frames(uu_video):
    path, frames = uu_video
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # two frames short of its header's count: no warning
        clip = VideoReader(path)
    with clip:
        assert clip.declared_frame_count == 428  # what the AVI header claims
        assert clip.frame_count == len(frames) == 426
        assert (clip.width, clip.height, clip.fps) == (644, 486, 50.0)
        assert len(clip) == 426 and clip.frame_numbers == range(426)


def test_uu_video_seeks_to_the_right_frame(uu_video):
    path, frames = uu_video
    with VideoReader(path) as clip:
        for i in (425, 3, 200, 201, 0, 424):  # backwards, forwards, next, first, last
            np.testing.assert_array_equal(clip.read(i), frames[i], err_msg=f"frame {i}")
        got = list(clip.frames(range(10, 400, 37)))
        assert [i for i, _ in got] == list(range(10, 400, 37))
        for i, frame in got:
            np.testing.assert_array_equal(frame, frames[i], err_msg=f"frame {i}")
        with pytest.raises(IPFError, match=r"frame 426 out of range \(0\.\.425\)"):
            clip.read(426)


def test_synthetic_video_round_trip(tmp_path):
    path = write_video(tmp_path / "clip.avi", 12)
    with VideoReader(path) as clip:
        assert clip.frame_count == 12 and (clip.width, clip.height) == (64, 48)
        assert clip.fps == pytest.approx(25.0)
        levels = [int(np.median(frame)) for _, frame in clip]
    np.testing.assert_allclose(levels, [(i * 20) % 250 for i in range(12)], atol=3)


def test_truncated_video_counts_what_decodes(tmp_path, shared_data, capfd):
    """A cut file: the frames that decode, one warning naming it, none of FFmpeg's own lines."""
    src = shared_data("uu_4cam_background") / "cam2" / "background.avi"
    data = src.read_bytes()
    path = tmp_path / "cut.avi"
    path.write_bytes(data[: int(len(data) * 0.6)])
    frames = decode_all(path)
    capfd.readouterr()
    with pytest.warns(IPFWarning, match=r"cut.avi: only \d+ of the \d+ frames it declares decode"):
        clip = VideoReader(path)
    with clip:
        assert clip.declared_frame_count > clip.frame_count == len(frames) > 0
        np.testing.assert_array_equal(clip.read(clip.frame_count - 1), frames[-1])
    noisy = write_video(tmp_path / "noisy.avi", 10, fps=20, noise=True)  # cut in a frame: FFmpeg
    noisy.write_bytes(noisy.read_bytes()[: noisy.stat().st_size // 2])
    with pytest.warns(IPFWarning, match=r"noisy.avi: only 4 of the 10 frames"):
        VideoReader(noisy).close()
    assert "@ 0x" not in capfd.readouterr().err  # FFmpeg's "[mjpeg @ 0x...] overread 8"


def _zero_frames(path):
    write_video(path, 0)


def _corrupt(path):
    path.write_bytes(np.random.default_rng(0).integers(0, 256, 5000, dtype=np.uint8).tobytes())


def _cut_header(path, shared_data):
    data = (shared_data("sports2d_walk") / "demo.mp4").read_bytes()
    path.write_bytes(data[:2000])  # inside the index (moov) atom


BAD_VIDEOS = {
    "missing": (None, "video file not found"),
    "empty_file": (lambda p, _: p.write_bytes(b""), r"zero-length video \(empty file\)"),
    "no_frames": (lambda p, _: _zero_frames(p), r"zero-length video \(no decodable frames\)"),
    "corrupt": (lambda p, _: _corrupt(p), "not a readable video"),
    "cut_header": (_cut_header, "not a readable video"),
}


@pytest.mark.parametrize("case", sorted(BAD_VIDEOS))
def test_bad_video_names_file_and_problem(tmp_path, shared_data, case):
    make, problem = BAD_VIDEOS[case]
    path = tmp_path / ("clip.mp4" if case == "cut_header" else "clip.avi")
    if make is not None:
        make(path, shared_data)
    with pytest.raises(IPFError) as info:
        VideoReader(path)
    assert info.value.path == str(path)
    assert re.search(problem, info.value.message), info.value.message


def test_closed_video_refuses_reads(tmp_path):
    clip = VideoReader(write_video(tmp_path / "clip.avi", 3))
    clip.close()
    with pytest.raises(IPFError, match="video is closed"):
        clip.read(0)


# --- image sequences -----------------------------------------------------------------------------

def test_bodytrack_image_sequence(bodytrack_dir):
    with ImageSequence(bodytrack_dir / "CAM1", mode="gray") as seq:
        assert seq.frame_count == 2 and seq.frame_numbers == [0, 1]
        assert (seq.width, seq.height, seq.fps) == (640, 480, None)
        frame = seq.read(1)
        np.testing.assert_array_equal(frame, cv2.imread(str(bodytrack_dir / "CAM1" /
                                                            "image0001.bmp"), cv2.IMREAD_GRAYSCALE))
    masks = ImageSequence(bodytrack_dir / "FG1", mode="mask")
    assert all(m.dtype == bool and m.any() for _, m in masks)


def test_image_sequence_orders_by_number_with_gaps(tmp_path):
    for n in (10, 3, 7):
        cv2.imwrite(str(tmp_path / f"image{n:04d}.png"), np.full((6, 8), n, np.uint8))
    cv2.imwrite(str(tmp_path / "background.png"), np.zeros((6, 8), np.uint8))  # not a frame
    seq = ImageSequence(tmp_path, fps=20.0, mode="gray")
    assert seq.frame_numbers == [3, 7, 10] and seq.fps == 20.0
    assert [int(img[0, 0]) for _, img in seq.frames([2, 0])] == [10, 3]
    with pytest.raises(IPFError, match="frame 3 out of range"):
        seq.read(3)


def test_image_sequence_problems(tmp_path):
    with pytest.raises(IPFError, match="image folder not found"):
        ImageSequence(tmp_path / "nope")
    with pytest.raises(IPFError, match="no imageNNNN"):
        ImageSequence(tmp_path)
    cv2.imwrite(str(tmp_path / "image0001.png"), np.zeros((6, 8), np.uint8))
    cv2.imwrite(str(tmp_path / "image0002.bmp"), np.zeros((7, 8), np.uint8))
    seq = ImageSequence(tmp_path)
    with pytest.raises(IPFError, match=r"image is 8x7, the sequence's first is 8x6") as info:
        seq.read(1)
    assert info.value.path == str(tmp_path / "image0002.bmp")
    cv2.imwrite(str(tmp_path / "image0002.png"), np.zeros((6, 8), np.uint8))
    with pytest.raises(IPFError, match="two files for frame 2"):
        ImageSequence(tmp_path)
    os.remove(tmp_path / "image0002.png")
    (tmp_path / "image0003.png").write_bytes(b"")
    with pytest.raises(IPFError, match="zero-byte") as info:
        ImageSequence(tmp_path).read(2)
    assert info.value.path == str(tmp_path / "image0003.png")
