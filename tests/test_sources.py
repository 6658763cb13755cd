"""dataset.json datasets (ipf_jax.data.sources): masks, images + background, video + median background,
region of interest, frame ranges, camera placement options, and one clear error per mistake."""
from __future__ import annotations

import json
import shutil
from pathlib import Path

import cv2
import numpy as np
import pytest

from ipf_jax.data.calibration import write_json
from ipf_jax.data.dataset import open_bodytrack, open_dataset
from ipf_jax.data.silhouette import foreground
from ipf_jax.errors import IPFError
from ipf_jax.viz.synthetic import look_at_camera

W, H, T = 96, 64, 21


def scene_background() -> np.ndarray:
    """A static textured background (smooth, so video compression keeps it)."""
    yy, xx = np.mgrid[0:H, 0:W]
    bg = np.stack([60 + 40 * np.sin(xx / 9.0), 90 + 30 * np.cos(yy / 7.0), 70 + 0 * xx], axis=-1)
    return bg.astype(np.uint8)


def person_box(t: int) -> tuple[int, int, int, int]:
    """(x0, y0, x1, y1) of the moving 'person' (a bright block walking left to right)."""
    x0 = 6 + 3 * t
    return x0, 18, x0 + 12, 56


def frame_image(t: int, extra: bool = False) -> np.ndarray:
    img = scene_background()
    x0, y0, x1, y1 = person_box(t)
    img[y0:y1, x0:x1] = (230, 230, 240)
    if extra:  # a second person in the top-left corner
        img[2:12, 2:10] = (240, 240, 240)
    return img


def truth_mask(t: int) -> np.ndarray:
    m = np.zeros((H, W), bool)
    x0, y0, x1, y1 = person_box(t)
    m[y0:y1, x0:x1] = True
    return m


def camera(width=W, height=H, name="cam1"):
    return look_at_camera((0.0, -6.0, 1.2), (0.0, 0.0, 1.2), width=width, height=height,
                          focal_px=80.0 * width / W, name=name)


def write_doc(folder: Path, doc: dict) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "dataset.json").write_text(json.dumps(doc))
    return folder


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    """A folder with a calibration, an image folder, a background image, masks and a video."""
    root = tmp_path_factory.mktemp("scene")
    write_json([camera()], root / "cameras.json")
    write_json([camera(2 * W, 2 * H)], root / "cameras_x2.json")
    for sub in ("images", "masks"):
        (root / sub).mkdir()
    writer = cv2.VideoWriter(str(root / "walk.avi"), cv2.VideoWriter_fourcc(*"MJPG"), 25.0, (W, H))
    assert writer.isOpened()
    for t in range(T):
        img = frame_image(t, extra=True)
        cv2.imwrite(str(root / "images" / f"image{t:04d}.png"), img)
        cv2.imwrite(str(root / "masks" / f"image{t:04d}.png"), truth_mask(t).astype(np.uint8) * 255)
        writer.write(img)
    writer.release()
    cv2.imwrite(str(root / "empty.png"), scene_background())
    return root


def base_doc(**camera_entry) -> dict:
    return {"calibration": "../cameras.json", "cameras": [camera_entry]}


def iou(a, b) -> float:
    return (a & b).sum() / max((a | b).sum(), 1)


def test_masks_folder_is_used_as_is_and_images_go_to_overlays(scene):
    ds = open_dataset(write_doc(scene / "d_masks", base_doc(masks="../masks", images="../images")))
    assert ds.layout == "ipf-jax" and ds.frames == list(range(T)) and ds.fps is None
    np.testing.assert_array_equal(ds.masks(7)[0], truth_mask(7))
    np.testing.assert_array_equal(ds.images(7)[0], frame_image(7, extra=True))
    assert ds.cameras[0].width == W


def test_images_minus_background_image_recover_the_person_exactly(scene):
    doc = base_doc(images="../images", background="../empty.png", roi=[0, 14, W, H],
                   segmentation={"open_px": 0, "close_px": 0})
    ds = open_dataset(write_doc(scene / "d_images", doc))
    for t in (0, 10, 20):  # lossless PNG frames: exact, and the corner 'person' is outside the ROI
        np.testing.assert_array_equal(ds.masks(t)[0], truth_mask(t))


def test_video_with_temporal_median_background(scene):
    doc = base_doc(video="../walk.avi", background={"median": 11}, roi=[0, 14, W, H])
    doc.update(frames="4:16")
    ds = open_dataset(write_doc(scene / "d_video", doc))
    assert ds.frames == list(range(4, 16))
    assert ds.fps == 25.0  # from the video
    for t in (4, 9, 15):
        assert iou(ds.masks(t)[0], truth_mask(t)) > 0.9, t
    image = ds.images(9)[0]
    assert image.shape == (H, W, 3) and image.dtype == np.uint8


def test_a_video_header_rate_beyond_any_camera_is_taken_as_unknown(scene, monkeypatch):
    """A header's 90 kHz (a stream's clock, not a frame rate) leaves the rate unknown, so the
    dataset opens and --fps can give it; only dataset.json's own 'fps' is refused beyond 10 kHz."""
    from ipf_jax.data import video

    opened = video.VideoReader.__init__

    def clock_rate(self, *args, **kwargs):  # what such a file's header reads as
        opened(self, *args, **kwargs)
        self.fps = 90000.0

    monkeypatch.setattr(video.VideoReader, "__init__", clock_rate)
    ds = open_dataset(write_doc(scene / "d_clock", base_doc(video="../walk.avi", background={"median": 3})))
    assert ds.fps is None and ds.frames == list(range(T))


def test_background_from_the_median_of_an_image_folder(scene):
    doc = base_doc(images="../images", background={"source": "../images", "median": 9,
                                                   "frames": "0:10"})
    ds = open_dataset(write_doc(scene / "d_folder_median", doc))
    mask = ds.masks(15)[0]
    assert not mask[:12, :12].any()  # the static corner 'person' is part of the background
    assert iou(mask, truth_mask(15)) > 0.9


def test_roi_polygon_and_cover_keep_one_person(scene):
    polygon = [[0, 14], [W - 1, 14], [W - 1, H - 1], [0, H - 1]]
    ds = open_dataset(write_doc(scene / "d_poly", base_doc(
        images="../images", background="../empty.png", roi=polygon)))
    assert not ds.masks(3)[0][:12].any()
    ds = open_dataset(write_doc(scene / "d_cover", base_doc(
        images="../images", background="../empty.png", segmentation={"cover": 0.8})))
    assert iou(ds.masks(3)[0], truth_mask(3)) > 0.95  # the small corner blob is dropped


def test_roi_crop_gives_the_same_mask_as_the_whole_frame(scene):
    doc = base_doc(images="../images", background="../empty.png", roi=[20, 10, 80, 60])
    ds = open_dataset(write_doc(scene / "d_crop", doc))
    roi = np.zeros((H, W), bool)
    roi[10:61, 20:81] = True
    whole = foreground(frame_image(9, extra=True), scene_background()) & roi
    np.testing.assert_array_equal(ds.masks(9)[0], whole)


def test_lighting_change_empties_the_mask(scene, tmp_path):
    (tmp_path / "imgs").mkdir()
    for t in range(3):
        img = frame_image(t) if t != 1 else np.clip(frame_image(t).astype(int) + 60, 0, 255)
        cv2.imwrite(str(tmp_path / "imgs" / f"image{t:04d}.png"), img.astype(np.uint8))
    doc = {"calibration": str(scene / "cameras.json"), "fps": 12.5,
           "segmentation": {"max_foreground": 0.3},
           "cameras": [{"images": "imgs", "background": str(scene / "empty.png")}]}
    ds = open_dataset(write_doc(tmp_path, doc))
    assert ds.fps == 12.5
    assert ds.masks(0)[0].any() and not ds.masks(1)[0].any() and ds.masks(2)[0].any()


def test_calibration_at_another_resolution_is_scaled(scene):
    doc = base_doc(masks="../masks")
    doc["calibration"] = "../cameras_x2.json"
    ds = open_dataset(write_doc(scene / "d_x2", doc))
    cam = ds.cameras[0]
    assert (cam.width, cam.height) == (W, H)
    np.testing.assert_allclose(cam.K[0, 0], camera().K[0, 0])
    np.testing.assert_allclose(cam.K[:2, 2], camera().K[:2, 2], atol=1e-9)


def test_camera_height_in_metres_moves_the_camera(scene):
    doc = base_doc(masks="../masks", name="cam1")
    doc.update(camera_height=2.5, up_axis="+z")
    ds = open_dataset(write_doc(scene / "d_height", doc))
    np.testing.assert_allclose(ds.cameras[0].centre, [0.0, -6.0, 2.5], atol=1e-9)
    np.testing.assert_allclose(ds.cameras[0].R, camera().R)


def test_shared_data_path_prefix(scene, monkeypatch):
    monkeypatch.setenv("IPF_JAX_DATA", str(scene))
    doc = {"calibration": "$IPF_JAX_DATA/cameras.json", "cameras": [{"masks": "$IPF_JAX_DATA/masks"}]}
    ds = open_dataset(write_doc(scene / "d_env", doc))
    assert len(ds.frames) == T


def test_bodytrack_described_by_dataset_json_matches_the_bodytrack_reader(bodytrack_dir, tmp_path):
    cams = [{"masks": str(bodytrack_dir / f"FG{k}"), "images": str(bodytrack_dir / f"CAM{k}")}
            for k in range(1, 5)]
    ds = open_dataset(write_doc(tmp_path, {"calibration": str(bodytrack_dir / "CALIB"),
                                           "cameras": cams}))
    ref = open_bodytrack(bodytrack_dir)
    assert ds.frames == ref.frames
    for a, b in zip(ds.cameras, ref.cameras):
        np.testing.assert_allclose(a.K, b.K)
        np.testing.assert_allclose(a.T, b.T)
    for a, b in zip(ds.masks(ds.frames[1]), ref.masks(ref.frames[1])):
        np.testing.assert_array_equal(a, b)
    image = ds.images(ds.frames[0])[0]
    assert image.shape == (480, 640, 3)


BAD = [
    ({"cameras": [{"masks": "../masks"}]}, "needs a 'calibration'"),
    ({**base_doc(masks="../masks"), "colour": 1}, r"unknown key\(s\) colour"),
    (base_doc(masks="../masks", video="../walk.avi"), "exactly one of 'masks', 'images' or 'video'"),
    (base_doc(), "exactly one of"),
    (base_doc(video="../nope.mp4"), "video file not found"),
    (base_doc(images="../images", background="../nope.png"), "background not found"),
    (base_doc(masks="../masks", background="../empty.png"), "masks take no background"),
    (base_doc(masks="../masks", segmentation={"threshold": 20}), "masks are used as they are"),
    (base_doc(images="../images", segmentation={"threshold": 300}), "threshold must be a number in 0..255"),
    (base_doc(images="../images", segmentation={"blur": 3}), r"unknown segmentation option\(s\) blur"),
    (base_doc(images="../images", background={"median": 0}), "median must be an integer in 1..1001"),
    ({**base_doc(masks="../masks"), "frames": "a:b"}, "'frames' must be"),
    ({**base_doc(masks="../masks"), "frames": "100:200"}, "camera 1.*selects none of the frames"),
    (base_doc(masks="../masks", roi=[500, 500, 600, 600]), "roi lies outside"),
    (base_doc(masks="../masks", roi=[10, 10, 5, 20]), "needs x0 < x1"),
    (base_doc(masks="../masks", roi="all"), "roi must be"),
    ({**base_doc(masks="../masks", name="camX")}, r"camera\(s\) camX not in the calibration"),
    ({"calibration": "../cameras.json", "cameras": [{"masks": "../masks"}, {"masks": "../masks"}]},
     "the calibration has 1 cameras but dataset.json lists 2"),
    ({**base_doc(masks="../masks"), "up_axis": "up"}, "'up_axis' must be one of"),
    ({**base_doc(masks="../masks"), "camera_height": "from_person"}, "needs 'height_m'"),
    ({**base_doc(masks="../masks"), "camera_height": -1, "up_axis": "+z"}, "camera_height"),
    ({**base_doc(masks="../masks"), "fps": -3}, "'fps' must be a positive number"),
    ({**base_doc(masks="../masks"), "fps": 0}, "'fps' must be a positive number up to 10000 Hz .*, got 0"),
    # tracked with every time_s 0.000000 (6 decimals): eval and gait then refused the run
    ({**base_doc(masks="../masks"), "fps": 1e9}, "'fps' must be a positive number up to 10000 Hz"),
    ({"calibration": "../cameras.json", "cameras": [{"masks": "../masks", "name": "cam1"},
                                                    {"masks": "../masks", "name": "cam1"}]},
     r"names camera\(s\) cam1 more than once"),
    ({**base_doc(masks="../masks"), "height_m": "tall"}, "'height_m' must be a standing height"),
    ({**base_doc(masks="../masks"), "height_m": -1}, r"'height_m' must be .* got -1"),
]


@pytest.mark.parametrize("k", range(len(BAD)), ids=[m for _, m in BAD])
def test_mistakes_raise_one_clear_error(scene, k):
    doc, message = BAD[k]
    folder = write_doc(scene / "bad" / str(k), doc)  # two levels down: "../" paths need one more
    doc = json.loads(json.dumps(doc).replace('"../', '"../../'))
    folder = write_doc(folder, doc)
    with pytest.raises(IPFError, match=message):
        open_dataset(folder)


def test_one_recording_for_two_cameras_is_an_error(scene, tmp_path):
    """It tracked silently, as if two cameras saw the same view."""
    write_json([camera(name="cam1"), camera(name="cam2")], tmp_path / "two.json")
    masks = str(scene / "masks")
    doc = {"calibration": "two.json", "cameras": [{"masks": masks, "name": "cam1"},
                                                  {"masks": masks + "/", "name": "cam2"}]}
    with pytest.raises(IPFError, match=r"camera 2 reads the masks .* of camera 1: each camera needs its own"):
        open_dataset(write_doc(tmp_path, doc))
    doc["cameras"][1]["masks"] = str(tmp_path / "other")  # a folder of its own: accepted
    shutil.copytree(masks, tmp_path / "other")
    assert len(open_dataset(write_doc(tmp_path, doc)).cameras) == 2


def test_background_of_another_size_is_an_error(scene, tmp_path):
    cv2.imwrite(str(tmp_path / "small.png"), np.zeros((10, 10, 3), np.uint8))
    doc = base_doc(images=str(scene / "images"), background=str(tmp_path / "small.png"))
    doc["calibration"] = str(scene / "cameras.json")
    ds = open_dataset(write_doc(tmp_path / "d", doc))
    with pytest.raises(IPFError, match="background is 10x10, the frames are 96x64"):
        ds.masks(0)


def test_unreadable_dataset_json(tmp_path):
    (tmp_path / "dataset.json").write_text("{not json")
    with pytest.raises(IPFError, match="dataset.json is not readable JSON"):
        open_dataset(tmp_path)


def test_sports2d_video_segments_the_walker(shared_data, tmp_path):
    """The real single-camera clip: median background from 5 nearby frames, ROI below the box."""
    from ipf_jax.geometry.placement import person_extent, stand_distance
    from ipf_jax.geometry.world import axis_vector

    clip = shared_data("sports2d_walk")
    doc = {"calibration": str(clip / "Calib_demo.toml"), "up_axis": "+z", "frames": "100:103",
           "segmentation": {"open_px": 5, "close_px": 15, "cover": 0.9},
           "cameras": [{"video": str(clip / "demo.mp4"), "roi": [0, 460, 1768, 994],
                        "background": {"median": 5, "frames": "60:160"}}]}
    ds = open_dataset(write_doc(tmp_path, doc))
    assert ds.frames == [100, 101, 102] and ds.fps == 30.0
    assert (ds.cameras[0].width, ds.cameras[0].height) == (1768, 994)
    for f in ds.frames:
        mask = ds.masks(f)[0]
        assert not mask[:460].any() and 8000 < mask.sum() < 60000, (f, mask.sum())
        feet, head = person_extent(mask)
        distance, cam_height = stand_distance(ds.cameras[0], feet, head, axis_vector("+z"), 1.65)
        # a 1.65 m walker about 10 m away; the nominal camera is 1.71 m above the floor
        assert 8.5 < distance < 11.5 and 1.5 < cam_height < 1.95, (f, distance, cam_height)


@pytest.mark.slow
def test_sports2d_example_dataset_places_the_camera(shared_data):
    shared_data("sports2d_walk")
    ds = open_dataset(Path(__file__).resolve().parent.parent / "docs" / "examples" / "sports2d_walk")
    assert ds.frames == list(range(60, 164)) and ds.height_m == 1.65
    assert 1.6 < ds.cameras[0].centre[2] < 1.9  # from the person; the nominal camera says 1.71 m
