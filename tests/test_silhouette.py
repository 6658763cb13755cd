"""Mask and image reading, mask resizing vs Camera.scaled, background subtraction, medians."""
from __future__ import annotations

import re
import tracemalloc

import cv2
import numpy as np
import pytest

from ipf_jax.data.calibration import read_bodytrack_cal, read_opencv_dir
from ipf_jax.data.silhouette import (
    foreground,
    largest_components,
    median_background,
    read_color,
    read_gray,
    read_mask,
    resize_mask,
)
from ipf_jax.data.video import VideoReader
from ipf_jax.errors import IPFError
from ipf_jax.geometry import host as ref

UU_CAMS = [1, 2, 3, 4]


def write(path, image):
    assert cv2.imwrite(str(path), image)
    return path


# --- reading -------------------------------------------------------------------------------------

def test_real_bodytrack_mask(bodytrack_dir):
    path = bodytrack_dir / "FG1" / "image0000.bmp"
    mask = read_mask(path)
    assert mask.dtype == bool and mask.shape == (480, 640)
    np.testing.assert_array_equal(mask, cv2.imread(str(path), cv2.IMREAD_GRAYSCALE) != 0)
    assert 0.005 < mask.mean() < 0.5
    assert read_gray(bodytrack_dir / "CAM1" / "image0000.bmp").shape == (480, 640)
    assert read_color(bodytrack_dir / "CAM1" / "image0000.bmp").shape == (480, 640, 3)


@pytest.mark.parametrize("ext", [".png", ".bmp"])
def test_mask_round_trip(tmp_path, ext):
    mask = np.random.default_rng(0).random((37, 53)) > 0.6
    path = write(tmp_path / f"m{ext}", mask.astype(np.uint8) * 7)  # any non-zero value
    np.testing.assert_array_equal(read_mask(path), mask)


def test_colour_mask_uses_colour_channels_not_alpha(tmp_path):
    rgba = np.zeros((4, 5, 4), np.uint8)
    rgba[..., 3] = 255  # opaque everywhere
    rgba[1, 2, 1] = 200  # one green pixel
    mask = read_mask(write(tmp_path / "m.png", rgba))
    assert mask.sum() == 1 and mask[1, 2]


def _png(tmp_path):
    return write(tmp_path / "ok.png", (np.random.default_rng(1).random((40, 60)) * 255)
                 .astype(np.uint8)).read_bytes()


def _bmp(tmp_path):
    return write(tmp_path / "ok.bmp", np.full((40, 60), 200, np.uint8)).read_bytes()


def _jpg(tmp_path):
    return write(tmp_path / "ok.jpg", (np.random.default_rng(2).random((40, 60, 3)) * 255)
                 .astype(np.uint8)).read_bytes()


BAD_IMAGES = {  # name: (file name, bytes from a good file -> bad bytes, problem)
    "missing": ("gone.png", None, "image file not found"),
    "zero_byte": ("empty.png", lambda b: b"", r"empty \(zero-byte\)"),
    "bmp_truncated_rows": ("t.bmp", lambda b: b[: len(b) - 100], r"truncated image: \d+ bytes, "
                           r"its BMP header needs \d+"),
    "bmp_truncated_last_byte": ("t.bmp", lambda b: b[:-1], "truncated image"),
    "bmp_truncated_header": ("t.bmp", lambda b: b[:20], "truncated image"),
    "png_truncated": ("t.png", lambda b: b[: len(b) // 2], "truncated image: PNG"),
    "png_no_iend": ("t.png", lambda b: b[:-12], "truncated image: PNG"),
    "jpg_truncated": ("t.jpg", lambda b: b[: len(b) * 2 // 3], "truncated image: JPEG"),
    "png_corrupt_data": ("c.png", lambda b: b[:41] + bytes(200) + b[241:], "corrupt"),
    "not_an_image": ("junk.png", lambda b: b"this is not an image at all" * 10, "corrupt"),
}


@pytest.mark.parametrize("reader", [read_mask, read_gray, read_color])
@pytest.mark.parametrize("case", sorted(BAD_IMAGES))
def test_bad_image_names_file_and_problem(tmp_path, case, reader):
    name, damage, problem = BAD_IMAGES[case]
    path = tmp_path / name
    if damage is not None:
        good = {".png": _png, ".bmp": _bmp, ".jpg": _jpg}[path.suffix](tmp_path)
        path.write_bytes(damage(good))
    with pytest.raises(IPFError) as info:
        reader(path)
    assert info.value.path == str(path)
    assert re.search(problem, info.value.message), info.value.message


def test_folder_is_not_an_image(tmp_path):
    with pytest.raises(IPFError, match="is a folder"):
        read_mask(tmp_path)


# --- resizing and Camera.scaled ------------------------------------------------------------------

def test_resize_mask_area_rule():
    mask = np.zeros((4, 4), bool)
    mask[0, 0:2] = True  # block (0, 0): 2 of 4 pixels -> kept (>= 0.5)
    mask[2, 2] = True  # block (1, 1): 1 of 4 -> dropped
    np.testing.assert_array_equal(resize_mask(mask, 2, 2), [[True, False], [False, False]])
    np.testing.assert_array_equal(resize_mask(mask, 4, 4), mask)
    with pytest.raises(IPFError, match="2-D"):
        resize_mask(np.zeros((4, 4, 3)), 2, 2)


def _centroid(weights):
    v, u = np.mgrid[: weights.shape[0], : weights.shape[1]]
    return np.array([(u * weights).sum(), (v * weights).sum()]) / weights.sum()


@pytest.mark.parametrize("scale", [0.5, 0.25])
def test_scaled_camera_agrees_with_resizing(bodytrack_dir, scale):
    """A blob drawn where a point projects at full size, area-resized, is centred where the
    scaled camera projects it: (u + 0.5) s - 0.5."""
    cam = read_bodytrack_cal(bodytrack_dir / "CALIB" / "Camera2.cal")
    small = cam.scaled(scale)
    assert (small.width, small.height) == (640 * scale, 480 * scale)
    X = np.array([[0.3, -0.2, 1.0], [-0.5, 0.4, 0.2], [0.0, 0.0, 1.6]])
    uv = ref.project_points(cam, X)[0]
    uv_small = ref.project_points(small, X)[0]
    np.testing.assert_allclose(uv_small, (uv + 0.5) * scale - 0.5, atol=1e-9)
    v, u = np.mgrid[: cam.height, : cam.width]
    for p, q in zip(uv, uv_small):
        d2 = (u - p[0]) ** 2 + (v - p[1]) ** 2
        blob = np.exp(-d2 / (2 * 4.0**2)).astype(np.float32)  # smooth: centroid exactly p
        area = cv2.resize(blob, (small.width, small.height), interpolation=cv2.INTER_AREA)
        np.testing.assert_allclose(_centroid(area), q, atol=1e-3)
        disc = d2 <= 16.0**2  # a hard mask only keeps its centre to a fraction of a pixel
        np.testing.assert_allclose(_centroid(resize_mask(disc, small.height, small.width)), q,
                                   atol=0.3)


# --- background subtraction ----------------------------------------------------------------------

def _scene(rng, colour=False):
    shape = (120, 160, 3) if colour else (120, 160)
    background = rng.integers(60, 120, shape).astype(np.uint8)
    frame = np.clip(background.astype(int) + rng.integers(-8, 9, shape), 0, 255).astype(np.uint8)
    person = np.zeros(shape[:2], bool)
    person[30:100, 60:90] = True
    frame[person] = 220
    frame[5, 5] = 255  # a one-pixel speck
    return frame, background, person


def test_foreground_finds_the_body_and_drops_specks():
    frame, background, person = _scene(np.random.default_rng(0))
    fg = foreground(frame, background)
    assert fg.dtype == bool and not fg[5, 5]
    assert (fg ^ person).sum() < 0.02 * person.sum()
    raw = foreground(frame, background, open_px=0, close_px=0)
    assert raw[5, 5] and (raw & ~person).sum() == 1


def test_foreground_colour_uses_the_largest_channel_difference():
    frame, background, person = _scene(np.random.default_rng(1), colour=True)
    frame[person] = background[person]
    frame[person, 2] = np.clip(background[person, 2].astype(int) + 60, 0, 255)  # only red changes
    fg = foreground(frame, background)
    assert (fg ^ person).sum() < 0.02 * person.sum()
    assert not foreground(frame, background, threshold=70).any()


def test_cover_keeps_the_largest_components():
    mask = np.zeros((50, 50), bool)
    mask[5:35, 5:25] = True  # 600 px
    mask[40:45, 40:45] = True  # 25 px
    np.testing.assert_array_equal(largest_components(mask, 0.9)[40:45, 40:45], False)
    np.testing.assert_array_equal(largest_components(mask, 0.99), mask)
    assert not largest_components(np.zeros((5, 5), bool), 0.9).any()
    frame = mask.astype(np.uint8) * 200
    fg = foreground(frame, np.zeros_like(frame), cover=0.9, open_px=0, close_px=0)
    np.testing.assert_array_equal(fg, mask & ~(np.arange(50)[:, None] >= 40))


def test_foreground_shape_mismatch():
    with pytest.raises(IPFError, match=r"frame shape \(4, 5\) differs from background shape"):
        foreground(np.zeros((4, 5), np.uint8), np.zeros((5, 4), np.uint8))


@pytest.fixture(scope="module")
def uu_silhouettes(shared_data):
    """Frame 200 of each uu camera against a 9-frame median of its empty-room clip."""
    root = shared_data("uu_4cam_background")
    out = []
    for k in UU_CAMS:
        with VideoReader(root / f"cam{k}" / "background.avi") as clip:
            background = median_background(clip, k=9)
        with VideoReader(root / f"cam{k}" / "video.avi") as clip:
            out.append(foreground(clip.read(200), background))
    return read_opencv_dir(root, 644, 486), out


@pytest.mark.parametrize("k", UU_CAMS)
def test_uu_person_on_chair_is_segmented(uu_silhouettes, k):
    _, masks = uu_silhouettes
    fg = masks[k - 1]
    n, _, stats, _ = cv2.connectedComponentsWithStats(fg.astype(np.uint8), connectivity=8)
    assert n > 1, "no foreground"
    x, y, w, h, area = stats[1 + np.argmax(stats[1:, cv2.CC_STAT_AREA])]
    assert 3000 < area < 0.15 * fg.size  # a seated person and a chair, not the room
    assert area > 0.6 * fg.sum()  # the person dominates the foreground
    assert 1.2 * w < h < 4 * w  # upright, taller than wide


def test_uu_silhouettes_agree_across_cameras(uu_silhouettes):
    """The rays through the 4 silhouette centroids nearly meet, at seated-torso height."""
    cams, masks = uu_silhouettes
    A, b, rays = np.zeros((3, 3)), np.zeros(3), []
    for cam, fg in zip(cams, masks):
        _, labels, stats, cents = cv2.connectedComponentsWithStats(fg.astype(np.uint8))
        c = cents[1 + np.argmax(stats[1:, cv2.CC_STAT_AREA])]
        xn = cv2.undistortPoints(c[None, None], cam.K, cam.dist).ravel()
        d = cam.R.T @ np.array([xn[0], xn[1], 1.0])
        d /= np.linalg.norm(d)
        P = np.eye(3) - np.outer(d, d)
        A, b = A + P, b + P @ cam.centre
        rays.append((cam.centre, P))
    X = np.linalg.solve(A, b)
    miss = [np.linalg.norm(P @ (X - o)) for o, P in rays]
    assert max(miss) < 0.15, miss  # metres
    assert 0.3 < -X[2] < 1.2  # -z is up in this world: between the seat and the head


# --- temporal median -----------------------------------------------------------------------------

class FakeClip:
    """A frame source with known frames, recording what was asked."""

    def __init__(self, frames):
        self._frames, self.frame_count, self.asked = frames, len(frames), []

    def frames(self, indices):
        for i in indices:
            self.asked.append(int(i))
            yield int(i), self._frames[i]


def test_median_background_is_the_median_of_evenly_spaced_frames():
    frames = np.random.default_rng(3).integers(0, 256, (40, 6, 7, 3)).astype(np.uint8)
    clip = FakeClip(frames)
    bg = median_background(clip, k=5)
    assert clip.asked == [0, 10, 20, 29, 39]
    np.testing.assert_array_equal(bg, np.median(frames[clip.asked], axis=0).astype(np.uint8))
    clip = FakeClip(frames)
    median_background(clip, k=100, start=35)
    assert clip.asked == [35, 36, 37, 38, 39]
    with pytest.raises(IPFError, match="outside the clip"):
        median_background(FakeClip(frames), start=40)


def test_median_of_a_long_video_holds_only_the_samples(shared_data):
    path = shared_data("sports2d_walk") / "demo.mp4"
    k = 5
    with VideoReader(path) as clip:
        frame_bytes = clip.width * clip.height * 3
        tracemalloc.start()
        try:
            bg = median_background(clip, k=k)
            peak = tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()
        assert bg.shape == (clip.height, clip.width, 3) and bg.dtype == np.uint8
        assert clip.frame_count == 230
    # k samples + the decoded frame + the result + small temporaries (the clip is 230 frames)
    assert peak < (k + 4) * frame_bytes, f"peak {peak / frame_bytes:.1f} frames"
    assert 30 < bg.mean() < 225  # a picture, not black or white
