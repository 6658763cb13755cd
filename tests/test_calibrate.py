"""ipf-jax calibrate on real boards: OpenCV's stereo sample (intrinsics and the pair's pose) and the
Utrecht floor board (extrinsics against the shipped config.xml made from the same board)."""
from __future__ import annotations

import json

import cv2
import pytest
import numpy as np

from ipf_jax.cli import main
from ipf_jax.data import board_calibration, checkerboard as cb
from ipf_jax.data.calibration import read_calibration, read_opencv


def test_stereo_pair_calibrates_below_half_a_pixel(shared_data, tmp_path, capsys):
    src = shared_data("opencv_stereo_calib")
    out = tmp_path / "cameras.json"
    assert main(["calibrate", "--board", "9x6", "--square", "0.025", "--camera",
                 f"left={src}/left*.jpg", "--camera", f"right={src}/right*.jpg",
                 "--max-error", "0.5", "--out", str(out)]) == 0, capsys.readouterr().err
    doc = json.loads(out.read_text())
    errs = {c["name"]: c["reprojection_error_px"] for c in doc["cameras"]}
    assert errs["left"]["intrinsics"] < 0.5 and errs["right"]["intrinsics"] < 0.5
    assert errs["right"]["extrinsics"] < 0.5  # the pair, 13 synchronised views
    left, right = read_calibration(out)
    baseline = np.linalg.norm(right.centre - left.centre)
    assert 0.05 < baseline < 0.12  # about 3.3 squares of 25 mm, side by side
    assert np.degrees(np.arccos((np.trace(right.R @ left.R.T) - 1) / 2)) < 2  # nearly parallel


def test_a_fit_above_max_error_is_refused_and_nothing_written(shared_data, tmp_path, capsys):
    src = shared_data("opencv_stereo_calib")
    out = tmp_path / "cameras.json"
    rc = main(["calibrate", "--board", "9x6", "--square", "0.025", "--camera",
               f"left={src}/left*.jpg", "--max-error", "0.1", "--out", str(out)])
    err = capsys.readouterr().err
    assert rc == 2 and "exceeds --max-error 0.1 px" in err and "\n" not in err.strip()
    assert not out.exists() and not list(tmp_path.iterdir())


def _board_error(cam, view, board):
    """RMS px of the board's corners projected by ``cam`` against a detection, over the numberings
    the symmetric board allows: a half turn (the file may number from either end) and, as the
    calibration does, the mirror that fixes the handedness (OpenCV 5's detector may number the
    corners that way)."""
    obj = board.object_points().astype(float)
    uv, _ = cv2.projectPoints(obj, cv2.Rodrigues(cam.R)[0], cam.T, cam.K, cam.dist)
    uv = uv.reshape(-1, 2)
    mirror = cb.mirrored(view, board)
    numberings = [view.uv] + ([] if mirror is None else [mirror.uv])
    return min(float(np.sqrt(((uv - p) ** 2).sum(1).mean())) for q in numberings for p in (q, q[::-1]))


def test_floor_board_extrinsics_fit_the_corners_no_worse_than_config_xml(shared_data, tmp_path,
                                                                        capsys):
    uu = shared_data("uu_4cam_background")
    out = tmp_path / "cameras.json"
    args = ["calibrate", "--board", "8x6", "--square", "0.115", "--max-error", "2",
            "--out", str(out)]
    for k in (1, 2, 3, 4):  # intrinsics from the lab's file (made from intrinsics.avi, not shipped)
        args += ["--intrinsics", f"cam{k}={uu}/cam{k}/config.xml",
                 "--floor", f"cam{k}={uu}/cam{k}/checkerboard.avi"]
    assert main(args) == 0, capsys.readouterr().err
    printed = capsys.readouterr().out
    ours = read_calibration(out)
    board = cb.parse_board("8x6", 0.115)
    # the symmetric board's numbering is taken from the layout of config.xml's own poses: as
    # detected, one camera's board (cam3's, or the other three's when cam1's detection starts at the
    # other end) puts it on the wrong side of the room (distance ratios 0.64-2.74)
    assert "floor board numbered from the other end" in printed
    shipped_centres = [read_opencv(uu / f"cam{k}" / "config.xml", 644, 486)[0].centre for k in (1, 2, 3, 4)]
    ratios = [np.linalg.norm(shipped_centres[i] - shipped_centres[j])
              / np.linalg.norm(ours[i].centre - ours[j].centre) for i in range(4) for j in range(i)]
    assert max(ratios) / min(ratios) < 1.15, ratios
    report = []
    for k, cam in enumerate(ours, start=1):
        shipped = read_opencv(uu / f"cam{k}" / "config.xml", 644, 486)[0]
        view, _ = cb.still_view(str(uu / f"cam{k}" / "checkerboard.avi"), board)
        e_ours, e_cfg = _board_error(cam, view, board), _board_error(shipped, view, board)
        assert e_ours <= e_cfg, f"cam{k}: {e_ours:.2f} px vs config.xml {e_cfg:.2f} px"
        report.append((k, e_ours, e_cfg, abs(cam.centre[2]) - abs(shipped.centre[2])))
    for row in report:
        print("cam%d: board corners %.2f px (config.xml %.2f px), height difference %+.3f m" % row)
    # every camera stands on one side of the floor (-z up, as config.xml)
    assert all(c.centre[2] < 0 for c in ours)


def _look_at(centre, target=(0.35, 0.25, 0.0)):
    """World->camera (R, t) of a camera at ``centre`` looking at ``target`` (z up, cameras above)."""
    f = np.asarray(target, float) - centre
    f /= np.linalg.norm(f)
    x = np.cross(f, [0.0, 0.0, -1.0])
    x /= np.linalg.norm(x)
    R = np.stack([x, np.cross(f, x), f])
    return R, -R @ centre


@pytest.mark.parametrize("turned, unposed", [("A", None), ("A", "D"), ("C", "D"), ("B", None)])
def test_floor_board_numbering_follows_the_files_camera_layout(turned, unposed):
    """SYNTHETIC: four cameras around an 8x6 floor board (below them: z of the board points away);
    one detection numbered from the other end; the files' poses are the true layout in another
    frame and unit (mm, shifted, turned), one camera's file has none. Every camera ends up where
    it stands, and the camera without a pose is never renumbered."""
    from ipf_jax.data.board_calibration import _floor_poses
    board = cb.parse_board("8x6", 0.1)
    K = np.array([[500.0, 0, 320], [0, 500, 240], [0, 0, 1]])
    centres = {"A": [3.0, 2.0, -2.0], "B": [-2.5, 2.2, -2.1], "C": [-2.2, -1.8, -1.9],
               "D": [2.8, -2.0, -2.2]}
    obj = board.object_points().astype(float)
    world_to_file = cv2.Rodrigues(np.array([0.0, 0.0, 0.7]))[0]
    views, intr = {}, {}
    for n, c in centres.items():
        c = np.asarray(c, float)
        R, t = _look_at(c)
        uv = cv2.projectPoints(obj, cv2.Rodrigues(R)[0], t, K, np.zeros(5))[0].reshape(-1, 2)
        if n == turned:
            uv = uv[::-1].copy()
        views[n] = cb.View(n, np.arange(len(obj)), uv)
        file_centre = None if n == unposed else 1000.0 * (world_to_file @ c + [5.0, -3.0, 1.0])
        intr[n] = cb.Intrinsics(K, np.zeros(5), float("nan"), 0, file_centre)
    req = board_calibration.Request({}, {}, {n: "x" for n in centres})
    poses, _, _, notes = _floor_poses(board, req, views, intr)
    found = {n: -R.T @ t for n, (R, t) in poses.items()}
    names = list(centres)
    d_true = [np.linalg.norm(np.subtract(centres[a], centres[b])) for a in names for b in names if a < b]
    d_found = [np.linalg.norm(found[a] - found[b]) for a in names for b in names if a < b]
    assert np.allclose(d_found, d_true, atol=1e-3), (d_found, d_true)
    assert notes and "numbered from the other end" in notes[0]
    if unposed:
        assert unposed not in notes[0].split(":")[0]


def test_bad_sizes_and_markers_are_one_error_line(tmp_path, capsys):
    from ipf_jax.cli import main

    for extra, message in ((["--size", "abc", "--intrinsics", "left=x.xml"], "--size must look like WIDTHxHEIGHT"),
                           (["--charuco", "--marker", "0.05", "--camera", "left=x*.jpg"],
                            "--marker must be positive and smaller than --square"),
                           (["--square", "inf", "--camera", "left=x*.jpg"],  # was an OpenCV internal error
                            "--square must be positive and finite, got inf"),
                           (["--camera", "left=a*.jpg", "--camera", "left=b*.jpg"],  # the first was dropped
                            "--camera left given twice")):
        code = main(["calibrate", "--board", "9x6", "--square", "0.025", *extra,
                     "--out", str(tmp_path / "c.json")])
        err = [x for x in capsys.readouterr().err.splitlines() if x.strip()]
        assert code == 2 and len(err) == 1 and message in err[0], err
