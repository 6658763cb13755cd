"""ipf-jax calibrate on real boards: OpenCV's stereo sample (intrinsics and the pair's pose) and the
Utrecht floor board (extrinsics against the shipped config.xml made from the same board)."""
from __future__ import annotations

import json

import cv2
import numpy as np

from ipf_jax.cli import main
from ipf_jax.data import checkerboard as cb
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
