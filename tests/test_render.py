"""Overlays and ``ipf-jax render``: self-rendered runs (no tracking), videos read back, colours
that tell a fitting pose from a wrong one, and one clear error per mistake."""
from __future__ import annotations

import json
import shutil

import cv2
import numpy as np
import pytest

from ipf_jax.body.shape import default_shape
from ipf_jax.cli import main
from ipf_jax.data.calibration import write_json
from ipf_jax.data.rundir import write_run_dir
from ipf_jax.data.video import VideoReader
from ipf_jax.geometry.world import up_rotation
from ipf_jax.viz import overlay
from ipf_jax.viz.render import render_run
from ipf_jax.viz.synthetic import (
    procedural_walk,
    render_masks,
    ring_cameras,
    write_dataset,
)

SHAPE = default_shape(1.72)
N = 4


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    """A 4-frame walk in 2 small cameras: bodytrack-layout masks, a dataset.json with images, and
    a run whose poses are the truth."""
    root = tmp_path_factory.mktemp("render")
    cams = ring_cameras(2, width=160, height=120, focal_px=150.0)
    q = procedural_walk(N, 20.0, shape=SHAPE, start=(-0.3, 0.0))
    masks = render_masks(q, SHAPE, cams)
    data = write_dataset(root / "data", cams, masks)
    for c in range(2):  # camera images for the dataset.json variant: grey person on a texture
        folder = root / "images" / f"CAM{c + 1}"
        folder.mkdir(parents=True)
        for t in range(N):
            img = np.full((120, 160, 3), 90, np.uint8)
            img[masks[t, c]] = 200
            cv2.imwrite(str(folder / f"image{t:04d}.png"), img)
    described = root / "described"
    described.mkdir()
    write_json(cams, described / "cameras.json")
    (described / "dataset.json").write_text(json.dumps({
        "calibration": "cameras.json",
        "cameras": [{"masks": f"../data/FG{c}", "images": f"../images/CAM{c}"} for c in (1, 2)]}))
    run = write_run_dir(root / "run", q, shape=SHAPE, fps=20.0,
                        meta={"dataset": str(data), "per_frame": [
                            {"frame": t, "status": "tracked", "weight": 3.5} for t in range(N)]})
    return {"root": root, "data": data, "described": described, "run": run, "q": q,
            "cams": cams, "masks": masks}


def colour_fraction(img: np.ndarray, colour) -> float:
    return float(np.mean(np.all(img == np.array(colour, np.uint8), axis=-1)))


def test_mask_overlay_colours_show_the_fit(scene):
    cam, mask, q = scene["cams"][0], scene["masks"][2, 0], scene["q"][2]
    U = up_rotation("+z")
    good = overlay.draw_view(mask, cam, q, SHAPE, U, long_side=640)
    wrong = q.copy()
    wrong[0] += 0.3  # 30 cm off
    bad = overlay.draw_view(mask, cam, wrong, SHAPE, U, long_side=640)
    assert good.shape == (480, 640, 3) and good.dtype == np.uint8
    # the OpenCV drawing and the scoring raster differ by edge pixels only
    assert colour_fraction(good, overlay.MODEL_ONLY) < 0.1 * colour_fraction(bad, overlay.MODEL_ONLY)
    assert colour_fraction(good, overlay.SILHOUETTE) < 0.1 * colour_fraction(bad, overlay.SILHOUETTE)
    big = overlay.draw_view(mask, cam, q, SHAPE, U, long_side=480, labels=("x",))
    assert big.shape == (360, 480, 3)


def test_model_silhouette_is_the_scoring_raster(scene):
    from ipf_jax.geometry.host import project_capsules
    from ipf_jax.likelihood.model_mask import model_mask

    cam = scene["cams"][0].scaled(3.0)
    caps = project_capsules(scene["q"][1], SHAPE.values, up_rotation("+z"), [cam])[0]
    drawn, exact = overlay.model_silhouette(caps, 360, 480), model_mask(caps, 360, 480)
    np.testing.assert_array_equal(drawn, exact)  # the same pixels, computed in a crop


def test_compose_grid_and_even_sizes():
    views = [np.full((5, 7, 3), k, np.uint8) for k in range(4)]
    out = overlay.compose(views, even=True)
    assert out.shape == (10, 14, 3)
    assert overlay.compose(views[:3]).shape == (5, 21, 3)
    assert overlay.compose(views[:1], even=True).shape == (6, 8, 3)


def test_render_video_reads_back(scene, tmp_path):
    summary = render_run(scene["run"], tmp_path / "o.mp4", progress=False)
    assert summary["kind"] == "video" and summary["frames"] == N and summary["background"] == "masks"
    with VideoReader(tmp_path / "o.mp4") as clip:
        assert clip.frame_count == N and clip.fps == pytest.approx(20.0)
        assert (clip.width, clip.height) == (2 * 480, 360)  # two views, default 480 px long side
    assert summary["mean_weight"] == 3.5


def test_render_folder_images_and_one_frame(scene, tmp_path):
    out = tmp_path / "frames"
    summary = render_run(scene["run"], out, dataset=scene["described"], cameras="2",
                         frames="1:3", size=200, progress=False)
    assert summary["background"] == "images" and summary["cameras"] == ["Camera2"]
    files = sorted(p.name for p in out.iterdir())
    assert files == ["frame00001.png", "frame00002.png"]
    assert cv2.imread(str(out / files[0])).shape == (150, 200, 3)
    one = tmp_path / "one.png"
    assert main(["render", str(scene["run"]), "--out", str(one), "--frames", "3", "--masks",
                 "--quiet"]) == 0
    assert cv2.imread(str(one)).shape == (360, 960, 3)
    tif = tmp_path / "one.tif"  # any still format cv2 writes, not a folder named one.tif
    assert main(["render", str(scene["run"]), "--out", str(tif), "--frames", "3", "--quiet"]) == 0
    assert tif.is_file() and cv2.imread(str(tif)).shape == (360, 960, 3)


def test_track_overlay_writer(scene, tmp_path):
    path = overlay.save_frame_overlay(tmp_path, 7, list(scene["masks"][0]), scene["cams"],
                                      scene["q"][0], SHAPE, up_rotation("+z"), 2.0)
    assert path.name == "frame00007.png" and cv2.imread(str(path)).shape == (360, 960, 3)


@pytest.mark.parametrize("extra,message", [
    (["--frames", "10:20"], "selects none of the frames"),
    (["--cameras", "Camera9"], "no camera 'Camera9'"),
    (["--size", "8"], "--size must be 32..4096"),
    (["--dataset", "/nonexistent/folder"], "dataset folder not found"),
    (["--images"], "no camera image for frame 0: use --masks"),
])
def test_render_mistakes(scene, tmp_path, capsys, extra, message):
    assert main(["render", str(scene["run"]), "--out", str(tmp_path / "x.mp4"), "--quiet",
                 *extra]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: ") and message in err and "\n" not in err


def test_render_refuses_media_it_cannot_write(scene, tmp_path, capsys):
    """--out walk.gif made a folder of PNGs named walk.gif and exited 0."""
    out = tmp_path / "walk.gif"
    assert main(["render", str(scene["run"]), "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: ") and "cannot write .gif files: give a .mp4" in err and "\n" not in err
    assert not out.exists()


def test_render_refuses_a_damaged_run_json(scene, tmp_path, capsys):
    run = tmp_path / "run"
    shutil.copytree(scene["run"], run)
    doc = json.loads((run / "run.json").read_text())
    (run / "run.json").write_text(json.dumps({**doc, "per_frame": 5}))
    assert main(["render", str(run), "--out", str(tmp_path / "x.mp4"), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert "per_frame is not a list of frames" in err and "\n" not in err


def test_render_needs_a_single_frame_for_a_png(scene, tmp_path, capsys):
    assert main(["render", str(scene["run"]), "--out", str(tmp_path / "x.png"), "--quiet"]) == 2
    assert "holds one frame, 4 selected" in capsys.readouterr().err


def test_render_needs_poses_and_a_known_dataset(scene, tmp_path, capsys):
    run = write_run_dir(tmp_path / "r", scene["q"], shape=SHAPE, fps=20.0)  # no dataset in run.json
    assert main(["render", str(run), "--out", str(tmp_path / "x.mp4"), "--quiet"]) == 2
    assert "names no dataset: give --dataset" in capsys.readouterr().err
    (run / "poses.csv").unlink()
    assert main(["render", str(run), "--out", str(tmp_path / "x.mp4"), "--quiet"]) == 2
    assert "has no poses.csv" in capsys.readouterr().err


def test_render_checks_the_cameras_against_the_run(scene, tmp_path, capsys):
    """A dataset with none of the run's cameras was drawn without a word (another recording)."""
    doc = json.loads((scene["run"] / "run.json").read_text())
    for tracked, code in ((["Room1", "Room2"], 2), (["Camera1"], 0), (["Camera1", "Camera2"], 0)):
        run = tmp_path / f"run{len(tracked)}{tracked[0]}"
        shutil.copytree(scene["run"], run)
        (run / "run.json").write_text(json.dumps({**doc, "cameras": tracked}))
        assert main(["render", str(run), "--out", str(tmp_path / "x.png"), "--frames", "1",
                     "--quiet"]) == code
        err = capsys.readouterr().err.strip()
        if code:
            assert err.startswith("error: ") and "none of the cameras drawn (Camera1, Camera2) is one " \
                "the run was tracked with (Room1, Room2)" in err and "\n" not in err
        elif len(tracked) == 1:  # a held-out view is drawn, and said
            assert err == "warning: drawing camera(s) Camera2 the run was not tracked with (the " \
                "model as their calibration places it)"
        else:
            assert err == ""
