"""Regressions found by running documented commands as a new user would (each failed before its fix).

* ``ipf-jax compare`` with the automatic initialisation (as docs/compare.md documents it) crashed
  in ``Tracker.check_view`` (the initial shape was passed on as a height): reproduced by
  ``tests/test_documented_commands.py::test_every_command_of_the_readme_table_runs`` (``compare``
  on the real sequenceB_2 with the automatic initialisation);
* ``ipf-jax render`` of cameras whose images differ in size and orientation crashed in
  ``overlay.compose`` (a top row narrower than the bottom row got a negative pad);
* ``--frames 30:40`` on a 32-frame data set tracked 2 frames without a word (now it warns).
"""
from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from ipf_jax.cli import main
from ipf_jax.data.calibration import read_bodytrack_cal, write_json
from ipf_jax.data.frames import parse_frames, select_frames
from ipf_jax.errors import IPFWarning
from ipf_jax.viz import overlay

WALK = "mocap_walk_render/rajagopal_walk_clean_4cam"


@pytest.mark.parametrize("sizes", [
    [(480, 240), (480, 240), (440, 600), (480, 640)],  # portrait top row, narrower than the bottom
    [(480, 640), (440, 600), (480, 240), (480, 250)],  # landscape top row, portrait bottom row
    [(1920, 1080), (1920, 1088), (1920, 1080), (1920, 1088)],  # a Qualisys-like sensor crop
])
def test_compose_pads_rows_of_any_width(sizes):
    views = [np.full((h, w, 3), k + 1, np.uint8) for k, (h, w) in enumerate(sizes)]
    out = overlay.compose(views, even=True)
    half = (len(views) + 1) // 2
    rows = [sizes[:half], sizes[half:]]
    assert out.shape[1] >= max(sum(w for _, w in r) for r in rows)
    assert out.shape[0] == 2 * max(h for h, _ in sizes) + out.shape[0] % 2
    assert out.shape[0] % 2 == 0 and out.shape[1] % 2 == 0
    assert out[0, 0, 0] == 1 and out[0, sizes[0][1], 0] == 2  # views side by side, in order


def _crop_rig(src, dst, crops):
    """A dataset.json copy of ``src`` with camera k's masks cropped to ``crops[k]`` = (x0, y0, w, h)
    and its principal point moved with the crop (cameras.json keeps each camera's own size)."""
    cams = []
    for k, (x0, y0, w, h) in enumerate(crops, start=1):
        cam = read_bodytrack_cal(src / "CALIB" / f"Camera{k}.cal")
        K = cam.K.copy()
        K[0, 2] -= x0
        K[1, 2] -= y0
        from dataclasses import replace

        cams.append(replace(cam, K=K, width=int(w), height=int(h), name=f"cam{k}"))
        folder = dst / f"FG{k}"
        folder.mkdir(parents=True)
        for f in sorted((src / f"FG{k}").glob("image000[0-1].png")):
            m = cv2.imread(str(f), cv2.IMREAD_GRAYSCALE)
            cv2.imwrite(str(folder / f.name), m[y0:y0 + h, x0:x0 + w])
    write_json(cams, dst / "cameras.json")
    (dst / "dataset.json").write_text(json.dumps({
        "calibration": "cameras.json", "fps": 20, "up_axis": "+z",
        "cameras": [{"name": f"cam{k}", "masks": f"FG{k}"} for k in range(1, len(crops) + 1)]}))


def _person_box(src, k):
    m = np.zeros((480, 640), bool)
    for f in sorted((src / f"FG{k}").glob("image000[0-1].png")):
        m |= cv2.imread(str(f), cv2.IMREAD_GRAYSCALE) > 0
    rows, cols = np.nonzero(m.any(1))[0], np.nonzero(m.any(0))[0]
    return rows[0], rows[-1], cols[0], cols[-1]


def test_render_cameras_of_different_sizes_and_orientations(shared_data, tmp_path, capsys):
    src = shared_data(WALK)
    crops = []
    for k in (1, 2, 3, 4):
        r0, _, c0, c1 = _person_box(src, k)
        if k <= 2:  # portrait: 240 px wide around the person, full height
            w = max(240, c1 - c0 + 21)
            x0 = int(np.clip((c0 + c1) // 2 - w // 2, 0, 640 - w))
            assert x0 <= c0 and x0 + w > c1, "the crop must keep the person"
            crops.append((x0, 0, w, 480))
        else:  # landscape, one of them cropped to 600x440 around the person
            crops.append((0, 0, 640, 480) if k == 4 else
                         (int(np.clip(c0 - 10, 0, 40)), int(np.clip(r0 - 10, 0, 40)), 600, 440))
    data = tmp_path / "mixed"
    _crop_rig(src, data, crops)
    run = tmp_path / "run"
    assert main(["track", str(data), "--out", str(run), "--frames", "0:2", "--init-budget", "small",
                 "--budget", "324", "--quiet"]) == 0
    png = tmp_path / "f.png"
    rc = main(["render", str(run), "--out", str(png), "--frames", "1", "--quiet"])
    err = capsys.readouterr().err
    assert rc == 0 and "Traceback" not in err, err
    img = cv2.imread(str(png))
    assert img is not None and img.shape[1] >= 240 + 240 and img.shape[0] >= 2 * 440


def test_partial_frame_range_warns_with_the_frames_used():
    with pytest.warns(IPFWarning, match=r"asks for 10 frames .* using 2 \(30\.\.31\)"):
        assert select_frames(range(32), parse_frames("30:40")) == [30, 31]
    with pytest.warns(IPFWarning, match="using 1 \\(31\\)"):
        select_frames(range(32), parse_frames("31:33"))


def test_track_warns_once_on_a_partial_frame_range(shared_data, tmp_path, capsys):
    rc = main(["track", str(shared_data(WALK)), "--out", str(tmp_path / "r"), "--frames", "31:40",
               "--init-budget", "small", "--budget", "324", "--quiet"])
    err = capsys.readouterr().err
    assert rc == 0, err
    lines = [ln for ln in err.splitlines() if ln.startswith("warning:")]
    assert len(lines) == 1 and "--frames 31:40" in lines[0] and "using 1 (31)" in lines[0]


def test_an_unexpected_exception_is_one_line_and_exit_70(monkeypatch, tmp_path, capsys):
    from ipf_jax.cli import track

    def broken(args):
        raise ZeroDivisionError("a bug\nover two lines")

    monkeypatch.setattr(track, "run", broken)
    rc = main(["track", str(tmp_path), "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert rc == 70
    assert err.strip().splitlines() == [
        "error: internal error in track: ZeroDivisionError: a bug over two lines "
        "(rerun with --debug for the traceback)"]
    with pytest.raises(ZeroDivisionError):
        main(["--debug", "track", str(tmp_path), "--out", str(tmp_path / "o")])
