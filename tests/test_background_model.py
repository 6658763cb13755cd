"""Backgrounds without the empty room: a synthetic person who stays put for most of a clip, and the
real Utrecht clip (a seated person who never leaves) against masks made with background.avi."""
from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from ipf_jax.data.background_model import (
    iou,
    mask_quality,
    shadow_mask,
    stable_background,
)
from ipf_jax.data.dataset import open_dataset
from ipf_jax.data.silhouette import foreground, median_background
from ipf_jax.data.sources import Segmentation, clean_mask
from ipf_jax.data.video import VideoReader


class FrameList:
    """The reader interface over frames in memory."""

    def __init__(self, frames):
        self._f = frames
        self.frame_count = len(frames)
        self.height, self.width = frames[0].shape[:2]

    def frames(self, indices):
        for i in indices:
            yield int(i), self._f[int(i)]


def _scene(rng, T=80, still_from=10, still_to=60):
    """A textured room; a dark box stands at one place for most frames, elsewhere before and
    after."""
    room = (rng.integers(60, 200, (1, 1, 3)) + 30 * np.sin(np.arange(160)[None, :, None] / 9)
            + 20 * np.cos(np.arange(120)[:, None, None] / 7)).clip(0, 255).astype(np.uint8)
    room = np.broadcast_to(room, (120, 160, 3)).copy()
    frames, boxes = [], []
    for t in range(T):
        x = 30 if still_from <= t < still_to else 110
        f = room.copy()
        f[40:100, x:x + 25] = (20, 30, 40)
        frames.append(f)
        boxes.append(x)
    return room, frames


def test_a_person_who_stays_put_most_of_the_clip_is_not_background():
    rng = np.random.default_rng(3)
    room, frames = _scene(rng)
    plain = median_background(FrameList(frames), 25)
    stable = stable_background(FrameList(frames))
    box = np.zeros(room.shape[:2], bool)
    box[40:100, 30:55] = True  # where the box stood still
    err_plain = np.abs(plain.astype(int) - room).max(2)[box].mean()
    err_stable = np.abs(stable.astype(int) - room).max(2)[box].mean()
    assert err_plain > 50  # the median keeps the box: it is there 50 of 80 frames
    assert err_stable < 10


def test_another_clip_with_a_board_in_it_gives_the_background():
    rng = np.random.default_rng(4)
    room, frames = _scene(rng, still_from=0, still_to=80)  # never leaves
    other = room.copy()
    cv2.rectangle(other, (100, 80), (140, 110), (255, 255, 255), -1)  # something else, elsewhere
    got = stable_background(FrameList(frames), [FrameList([other] * 11)])
    assert np.abs(got.astype(int) - other).max() == 0  # the other clip where it is valid


def test_shadow_pixels_are_darker_background_of_the_same_colour():
    bg = np.full((10, 10, 3), (60, 160, 40), np.uint8)
    frame = bg.copy()
    frame[:5] = (bg[:5] * 0.6).astype(np.uint8)  # a shadow
    frame[5:, :5] = (200, 20, 200)  # a person in magenta
    sh = shadow_mask(frame, bg)
    assert sh[:5].all() and not sh[5:].any()


def test_mask_quality_figures():
    one = np.zeros((50, 50), bool)
    one[10:40, 20:30] = True
    two = one.copy()
    two[0:20, 0:10] = True  # a second big blob
    q = mask_quality([one, one, two, np.zeros_like(one)])
    assert q["frames"] == 4 and q["empty_share"] == 0.25
    assert q["one_blob_share"] == pytest.approx(2 / 3, abs=1e-4)
    assert q["median_blobs"] == 1.0


SEG = Segmentation(cover=0.95)  # init-dataset's clean-up, for both sets of masks


@pytest.fixture(scope="module")
def uu(shared_data):
    return shared_data("uu_4cam_background")


def test_uu_masks_without_the_empty_room_match_those_with_it(uu):
    """The person never leaves their chair: the recording alone cannot show what is behind them.
    The board clip of each camera (an empty room with a board on the floor, the board masked out
    and the floor inpainted) can: mean IoU against the background.avi masks >= 0.85."""
    from ipf_jax.data.checkerboard import parse_board

    board = parse_board("8x6", 0.115)
    per_camera = []
    for k in (1, 2, 3, 4):
        video = VideoReader(uu / f"cam{k}" / "video.avi")
        empty = median_background(VideoReader(uu / f"cam{k}" / "background.avi"), 25)
        ours = stable_background(video, [VideoReader(uu / f"cam{k}" / "checkerboard.avi")],
                                 board=board)
        scores = [iou(clean_mask(foreground(f, empty), SEG), clean_mask(foreground(f, ours), SEG))
                  for _, f in video.frames(range(0, video.frame_count, 60))]
        per_camera.append(np.mean(scores))
    print("IoU per camera", np.round(per_camera, 3))
    assert np.mean(per_camera) >= 0.85 and min(per_camera) > 0.8


def test_stable_background_from_dataset_json(uu, tmp_path):
    doc = {"calibration": str(uu), "fps": 50, "up_axis": "-z", "frames": "0:3",
           "segmentation": {"cover": 0.95, "shadows": True},
           "cameras": [{"name": "cam1", "video": str(uu / "cam1" / "video.avi"),
                        "background": {"model": "stable",
                                       "also": str(uu / "cam1" / "checkerboard.avi"),
                                       "board": "8x6"}}]}
    (tmp_path / "dataset.json").write_text(json.dumps(doc))
    ds = open_dataset(tmp_path)
    m = ds.masks(0)[0]
    assert 8000 < m.sum() < 14000  # the seated person (and chair), not the board or the room
    q = mask_quality(ds.masks(f)[0] for f in ds.frames)
    assert q["one_blob_share"] == 1.0 and q["empty_share"] == 0.0


def test_mask_quality_accumulates_per_camera_frame_by_frame():
    from ipf_jax.data.background_model import MaskQuality

    one = np.zeros((20, 20), bool)
    one[5:15, 5:10] = True
    acc = MaskQuality()
    acc.add([one, np.zeros_like(one)])
    acc.add([one, one])
    a, b = acc.summary(["cam1", "cam2"])
    assert a["camera"] == "cam1" and a["one_blob_share"] == 1.0 and a["empty_share"] == 0.0
    assert b["empty_share"] == 0.5 and b["frames"] == 2
