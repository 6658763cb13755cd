"""Lab calibration formats (Qualisys, Vicon, OptiTrack) written from the visible rigs and read back,
their reprojection against today's readers, the one-line messages for other kinds of file, and a
visible render tracked through every supported format from a dataset.json made by init-dataset."""
from __future__ import annotations

import json
import shutil
import warnings

import cv2
import numpy as np
import pytest

from ipf_jax.cli import main
from ipf_jax.data.calibration import read_calibration, write_json
from ipf_jax.data.calibration_formats import (
    write_optitrack,
    write_qualisys,
    write_vicon,
)
from ipf_jax.data.runfiles import read_joints_csv
from ipf_jax.errors import IPFError

WALK = "mocap_walk_render/rajagopal_walk_clean_4cam"
UU = "mocap_walk_render/rajagopal_walk_uu_clean_4cam"
WRITERS = {"qualisys": (write_qualisys, "Calib.qca.txt"), "vicon": (write_vicon, "calib.xcp"),
           "optitrack": (write_optitrack, "System Calibration.mcal")}
# worst pixel difference from the original camera on points inside its image: the Qualisys and
# Motive layouts hold the model exactly; Vicon's 3-coefficient lens (distorted -> ideal) is fitted
# both ways, which costs a little on bodytrack's lenses and up to 2.3 px at the edges of the
# strongly distorted Utrecht ones (k1 = -0.37)
TOLERANCE = {"bodytrack": {"qualisys": 1e-4, "vicon": 0.05, "optitrack": 1e-4},
             "uu": {"qualisys": 1e-4, "vicon": 3.0, "optitrack": 1e-4}}


def _project(cam, X):
    uv, _ = cv2.projectPoints(X, cv2.Rodrigues(cam.R)[0], cam.T, cam.K, cam.dist)
    return uv.reshape(-1, 2)


@pytest.fixture(scope="module")
def rigs(shared_data):
    return {"bodytrack": read_calibration(shared_data(WALK) / "CALIB"),
            "uu": read_calibration(shared_data(UU) / "CALIB" / "cameras.json")}


@pytest.mark.parametrize("rig", ["bodytrack", "uu"])
@pytest.mark.parametrize("fmt", sorted(WRITERS))
def test_rig_written_in_a_lab_format_reprojects_like_todays_reader(rigs, tmp_path, rig, fmt):
    cams = rigs[rig]
    write, name = WRITERS[fmt]
    write(cams, tmp_path / name)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # Vicon: "edges differ" on the Utrecht lenses
        back = read_calibration(tmp_path / name)
    assert [c.name for c in back] == [c.name for c in cams]
    rng = np.random.default_rng(0)
    for a, b in zip(cams, back):
        assert (b.width, b.height) == (a.width, a.height)
        np.testing.assert_allclose(b.centre, a.centre, atol=1e-6)
        X = a.centre + 3.0 * a.R[2] + rng.uniform(-1.5, 1.5, (3000, 3))  # around the view axis
        ua, ub = _project(a, X), _project(b, X)
        inside = (ua[:, 0] >= 0) & (ua[:, 0] < a.width) & (ua[:, 1] >= 0) & (ua[:, 1] < a.height)
        assert inside.sum() > 300
        assert np.abs(ua - ub)[inside].max() < TOLERANCE[rig][fmt], f"{a.name}"


QCA = """<?xml version="1.0" encoding="UTF-8"?>
<QTM_Parameters_Ver_1.25>
 <calibration calibrated="true" source="Calib.qca" type="regular">
  <cameras>
   <camera active="1" calibrated="true" serial="28526" model="Miqus Video" viewrotation="0">
    <fov_marker left="0" top="0" right="1919" bottom="1087"/>
    <fov_video left="8" top="0" right="1095" bottom="1919"/>
    <transform x="0" y="-4000" z="1200" r11="1" r12="0" r13="0" r21="0" r22="0" r23="1"
     r31="0" r32="-1" r33="0"/>
    <intrinsic focallength="6.2" sensorMinU="0" sensorMaxU="70655" sensorMinV="0"
     sensorMaxV="122879" focalLengthU="96000" focalLengthV="96064" centerPointU="35328"
     centerPointV="61440" skew="0" radialDistortion1="-0.05" radialDistortion2="0.14"
     radialDistortion3="0" tangentalDistortion1="0.0006" tangentalDistortion2="-0.0004"/>
   </camera>
  </cameras>
 </calibration>
</QTM_Parameters_Ver_1.25>
"""


def test_qualisys_layout_from_its_description(tmp_path):
    """A QTM camera 4 m behind the origin at 1.2 m, looking along +y (QTM: y up, looking along
    -z in its own frame), 1/64-pixel intrinsics and a video window starting at column 8."""
    path = tmp_path / "Calib.qca.txt"
    path.write_text(QCA)
    (cam,) = read_calibration(path)
    assert (cam.name, cam.width, cam.height) == ("28526", 1088, 1920)
    np.testing.assert_allclose(np.diag(cam.K)[:2], [1500.0, 1501.0])
    np.testing.assert_allclose(cam.K[:2, 2], [552.0 - 8, 960.0])
    np.testing.assert_allclose(cam.centre, [0.0, -4.0, 1.2])
    np.testing.assert_allclose(cam.view_dir, [0.0, 1.0, 0.0], atol=1e-12)  # into the room
    assert cam.R[1] @ [0, 0, 1] < 0  # world up is image up (v decreases)
    np.testing.assert_allclose(cam.dist, [-0.05, 0.14, 0.0006, -0.0004, 0.0])
    uv = _project(cam, np.array([[0.0, 0.0, 1.2]]))  # straight ahead: the principal point
    np.testing.assert_allclose(uv[0], cam.K[:2, 2], atol=1e-9)


@pytest.mark.parametrize("name, content, what", [
    ("Config.toml", '[project]\nmulti_person = false\nframe_rate = "auto"\n[pose]\n'
     'pose_model = "HALPE_26"\n[calibration]\ncalibration_type = "convert"\n',
     "a Pose2Sim project file"),
    ("frame0001.jpg", b"\xff\xd8\xff\xe0" + b"\x00" * 64, "a JPEG image"),
    ("walk.trc", "PathFileType\t4\t(X/Y/Z)\twalk.trc\n", "a TRC marker file"),
    ("dataset.json", '{"calibration": "c.json", "cameras": [{"masks": "FG1"}]}',
     "a dataset.json"),
    ("System Calibration.cal", b"\x01\x00\x02\x00" * 40, "Motive before 3.2"),
    ("room.xml", "<?xml version='1.0'?><scene><light/></scene>", "root element is <scene>"),
    ("video.avi", b"RIFF\x00\x00\x00\x00AVI LIST", "a RIFF file"),
])
def test_another_kind_of_file_is_named_in_one_line(tmp_path, name, content, what):
    path = tmp_path / name
    path.write_bytes(content.encode() if isinstance(content, str) else content)
    with pytest.raises(IPFError) as info:
        read_calibration(path)
    msg = str(info.value)
    assert what in msg and "\n" not in msg and str(path) in msg
    assert "Qualisys .qca.txt" in msg and "docs/formats.md" in msg


def test_track_on_a_video_or_an_image_folder_points_to_init_dataset(shared_data, tmp_path, capsys):
    video = shared_data("uu_4cam_background") / "cam1" / "video.avi"
    for target in (video, shared_data("opencv_stereo_calib")):
        rc = main(["track", str(target), "--out", str(tmp_path / "r")])
        err = capsys.readouterr().err.strip()
        assert rc == 2 and "\n" not in err and "Traceback" not in err
        assert "ipf-jax init-dataset" in err and "docs/formats.md" in err


def _write_opencv_dir(cams, root):
    for k, c in enumerate(cams, start=1):
        d = root / f"cam{k}"
        d.mkdir(parents=True)
        fs = cv2.FileStorage(str(d / "config.xml"), cv2.FILE_STORAGE_WRITE)
        fs.write("CameraMatrix", c.K)
        fs.write("DistortionCoeffs", c.dist.reshape(1, 5))
        fs.write("Rotation", cv2.Rodrigues(c.R)[0])
        fs.write("Translation", (c.T * 1000).reshape(3, 1))
        fs.release()
    return root


def _write_toml(cams, path):
    rows = []
    for c in cams:
        rows.append(f'[{c.name}]\nname = "{c.name}"\nsize = [ {c.width}, {c.height}]\n'
                    f"matrix = {json.dumps(c.K.tolist())}\n"
                    f"distortions = {json.dumps(c.dist.tolist())}\n"
                    f"rotation = {json.dumps(cv2.Rodrigues(c.R)[0].ravel().tolist())}\n"
                    f"translation = {json.dumps(c.T.tolist())}\nfisheye = false\n")
    path.write_text("\n".join(rows) + '\n[metadata]\nadjusted = false\nerror = 0.0\n')
    return path


def _calibration(fmt, cams, src, tmp):
    if fmt == "bodytrack_cal":
        shutil.copytree(src / "CALIB", tmp / "CALIB")
        return tmp / "CALIB"
    if fmt == "opencv_xml":
        return _write_opencv_dir(cams, tmp / "opencv")
    if fmt == "toml":
        return _write_toml(cams, tmp / "Calib.toml")
    if fmt == "json":
        write_json(cams, tmp / "cameras.json")
        return tmp / "cameras.json"
    write, name = WRITERS[fmt]
    return write(cams, tmp / name)


FORMATS = ["bodytrack_cal", "opencv_xml", "toml", "json", "qualisys", "vicon", "optitrack"]


@pytest.mark.parametrize("fmt", FORMATS)
def test_visible_render_tracks_through_each_calibration_format(shared_data, tmp_path, fmt, capsys):
    src = shared_data(WALK)
    cams = read_calibration(src / "CALIB")
    calib = _calibration(fmt, cams, src, tmp_path)
    data = tmp_path / "data"
    assert main(["init-dataset", *[str(src / f"FG{k}") for k in (1, 2, 3, 4)], "--masks",
                 "--calibration", str(calib), "--out", str(data), "--fps", "20",
                 "--up", "+z"]) == 0
    doc = json.loads((data / "dataset.json").read_text())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        names = [c.name for c in read_calibration(calib, 640, 480)]
    assert [e["name"] for e in doc["cameras"]] == names  # matched by order, named as written
    run = tmp_path / "run"
    assert main(["track", str(data), "--out", str(run), "--frames", "0:2", "--init-budget",
                 "small", "--budget", "324", "--quiet"]) == 0, capsys.readouterr().err
    got = read_joints_csv(run / "joints.csv").points
    gt = np.loadtxt(src / "ground_truth.csv", delimiter=",", skiprows=1)[:2]
    assert np.isfinite(got).all() and got.shape[0] == 2
    # the pelvis region lands where the walker is (the render's hips, metres)
    hips = gt[:, 3 + 3 * 1:3 + 3 * 2]
    assert np.linalg.norm(got[:, 1] - hips, axis=1).max() < 0.25
