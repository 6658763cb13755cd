"""Calibration readers on the real files, projection against OpenCV, up axis, bad input."""
from __future__ import annotations

import re
import shutil

import cv2
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from ipf_jax.data.calibration import (
    read_bodytrack_cal,
    read_bodytrack_dir,
    read_calibration,
    read_json,
    read_opencv,
    read_opencv_dir,
    read_toml,
    rodrigues,
    write_json,
)
from ipf_jax.errors import IPFError
from ipf_jax.geometry import camera as jcam
from ipf_jax.geometry import host as ref
from ipf_jax.geometry.world import contradicted_up, detect_up_axis
from ipf_jax.reference import PIXEL_ATOL

BODYTRACK_CENTRES = np.array([[2.761, 2.547, 2.539], [-2.121, 2.446, 2.578],
                              [-2.033, -1.872, 2.528], [2.854, -1.892, 2.535]])
UU_SIZE = (644, 486)  # the first frame of every uu video


@pytest.fixture(scope="module")
def bodytrack_cams(bodytrack_dir):
    return read_calibration(bodytrack_dir / "CALIB")


@pytest.fixture(scope="module")
def uu_dir(shared_data):
    return shared_data("uu_4cam_background")


@pytest.fixture(scope="module")
def uu_cams(uu_dir):
    return read_opencv_dir(uu_dir, *UU_SIZE)


@pytest.fixture(scope="module")
def sports2d_toml(shared_data):
    return shared_data("sports2d_walk") / "Calib_demo.toml"


def assert_same_cameras(a, b):
    assert len(a) == len(b)
    for ca, cb in zip(a, b):
        for f in ("K", "dist", "R", "T"):
            np.testing.assert_array_equal(getattr(ca, f), getattr(cb, f), err_msg=f"{ca.name}.{f}")
        assert (ca.width, ca.height, ca.name) == (cb.width, cb.height, cb.name)


# --- the real files ------------------------------------------------------------------------------

def test_bodytrack_centres_in_metres(bodytrack_cams):
    assert [c.name for c in bodytrack_cams] == ["Camera1", "Camera2", "Camera3", "Camera4"]
    np.testing.assert_allclose([c.centre for c in bodytrack_cams], BODYTRACK_CENTRES, atol=2e-3)
    assert bodytrack_cams[0].dist[0] == pytest.approx(-0.3172978596)


def test_bodytrack_sequence_folder_finds_calib(bodytrack_dir, bodytrack_cams):
    assert_same_cameras(read_calibration(bodytrack_dir), bodytrack_cams)


def test_camera_files_sort_numerically(tmp_path, bodytrack_dir):
    for k in (1, 2, 10):
        shutil.copy(bodytrack_dir / "CALIB" / "Camera1.cal", tmp_path / f"Camera{k}.cal")
    assert [c.name for c in read_bodytrack_dir(tmp_path)] == ["Camera1", "Camera2", "Camera10"]


def test_opencv_xml_matches_filestorage(uu_dir, uu_cams):
    assert [c.name for c in uu_cams] == ["cam1", "cam2", "cam3", "cam4"]
    for k, cam in enumerate(uu_cams, 1):
        fs = cv2.FileStorage(str(uu_dir / f"cam{k}" / "config.xml"), cv2.FILE_STORAGE_READ)
        # the reader keeps the file's decimals; FileStorage.mat() rounds them to float32 ("dt f")
        np.testing.assert_allclose(cam.K, fs.getNode("CameraMatrix").mat(), rtol=1e-7)
        np.testing.assert_allclose(cam.dist, fs.getNode("DistortionCoeffs").mat().ravel(),
                                   rtol=1e-7)
        np.testing.assert_allclose(cam.R, cv2.Rodrigues(fs.getNode("Rotation").mat())[0],
                                   atol=1e-12)
        np.testing.assert_allclose(cam.T, fs.getNode("Translation").mat().ravel() / 1000)
        assert (cam.width, cam.height) == UU_SIZE
        assert 3.0 < np.linalg.norm(cam.centre) < 7.0  # metres, a room


def test_opencv_units_and_size_are_explicit(uu_dir):
    path = uu_dir / "cam1" / "config.xml"
    mm = read_opencv(path, *UU_SIZE)[0]
    m = read_opencv(path, *UU_SIZE, units="m")[0]
    np.testing.assert_allclose(m.T, mm.T * 1000)
    with pytest.raises(IPFError, match="image size is not in the calibration file"):
        read_opencv(path)
    with pytest.raises(IPFError, match="unknown units 'inch'"):
        read_opencv(path, *UU_SIZE, units="inch")


def test_opencv_yaml_3x3_rotation_and_zero_extra_terms(tmp_path):
    R = rodrigues(np.array([0.1, -0.4, 0.2]))
    K = np.array([[500.0, 0, 320], [0, 505, 240], [0, 0, 1]])
    path = tmp_path / "calib.yml"
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    fs.write("image_width", 640)
    fs.write("image_height", 480)
    fs.write("camera_matrix", K)
    fs.write("distortion_coefficients", np.array([[-0.2, 0.05, 1e-3, -2e-3, 0.01, 0, 0, 0]]))
    fs.write("Rotation", R)
    fs.write("Translation", np.array([[100.0], [-50.0], [3000.0]]))
    fs.release()
    (cam,) = read_calibration(path)
    np.testing.assert_array_equal(cam.K, K)
    np.testing.assert_array_equal(cam.R, R)
    np.testing.assert_array_equal(cam.dist, [-0.2, 0.05, 1e-3, -2e-3, 0.01])
    np.testing.assert_allclose(cam.T, [0.1, -0.05, 3.0])
    assert (cam.width, cam.height, cam.name) == (640, 480, "calib")


def test_toml_sports2d(sports2d_toml):
    (cam,) = read_calibration(sports2d_toml)
    assert (cam.name, cam.width, cam.height) == ("demo", 1768, 994)
    assert cam.K[0, 0] == pytest.approx(2520.0897058227038)
    np.testing.assert_array_equal(cam.dist, np.zeros(5))
    rvec = np.array([1.2082126924727719, 1.2098328575850605, -1.2082126924727719])
    np.testing.assert_allclose(cam.R, cv2.Rodrigues(rvec)[0], atol=1e-12)
    np.testing.assert_array_equal(cam.T, [-3.510103521992233, 1.7079310029359385, 10.0])


def test_json_round_trip_is_exact(tmp_path, bodytrack_cams, uu_cams, sports2d_toml):
    cams = bodytrack_cams + uu_cams + read_toml(sports2d_toml)
    write_json(cams, tmp_path / "cameras.json")
    assert_same_cameras(read_calibration(tmp_path / "cameras.json"), cams)


def test_dispatch_sniffs_unknown_extension(tmp_path, sports2d_toml, bodytrack_dir):
    shutil.copy(sports2d_toml, tmp_path / "calib.txt")
    assert read_calibration(tmp_path / "calib.txt")[0].name == "demo"
    shutil.copy(bodytrack_dir / "CALIB" / "Camera2.cal", tmp_path / "cam2.dat")
    assert read_calibration(tmp_path / "cam2.dat")[0].name == "cam2"


# --- up axis -------------------------------------------------------------------------------------

def test_up_axis_bodytrack(bodytrack_cams):
    assert detect_up_axis(bodytrack_cams) == "+z"


def test_uu_and_sports2d_geometry_says_which_way_is_up(uu_cams, sports2d_toml):
    """The evidence the up-axis tests below rely on, checked directly."""
    for cam in uu_cams:  # -z up: tripods 1.6-2.2 m high, looking about level, not rolled
        assert 1.5 < -cam.centre[2] < 2.3
        assert abs(cam.view_dir[2]) < 0.2
        assert (cam.R.T @ [0, -1, 0])[2] < -0.95  # image up is world -z
    (cam,) = read_toml(sports2d_toml)  # +z up: 1.71 m high, looking level along -x, not rolled
    np.testing.assert_allclose(cam.centre, [10.0, 3.508, 1.713], atol=2e-3)
    np.testing.assert_allclose(cam.view_dir, [-1, 0, 0], atol=2e-3)
    assert (cam.R.T @ [0, -1, 0])[2] > 0.999


def test_up_axis_uu(uu_cams):
    assert detect_up_axis(uu_cams) == "-z"


def test_up_axis_sports2d(sports2d_toml):
    assert detect_up_axis(read_toml(sports2d_toml)) == "+z"


def test_up_axis_single_camera_from_its_orientation(shared_data):
    """One bodytrack ceiling camera (mounted upside down, tilted down): its image's vertical says
    which axis is up, its height which way; a seated person on the first frame changes nothing."""
    from ipf_jax.data.silhouette import read_mask

    root = shared_data("mocap_walk_render/rajagopal_walk_clean_1cam")
    cams = read_calibration(root / "CALIB")
    assert detect_up_axis(cams, [read_mask(root / "FG1" / "image0000.png")]) == "+z"
    for name in ("sub4_sts_noisy_1cam", "sub4_sts_weaklegs_noisy_1cam"):  # seated on frame 0
        root = shared_data(f"mocap_walk_render/{name}")
        assert detect_up_axis(read_calibration(root / "CALIB"),
                              [read_mask(root / "FG1" / "image0000.png")]) == "+z", name
    bt = shared_data("parsec_bodytrack/sequenceB_2")
    for k in (1, 3, 4):
        cam = read_calibration(bt / "CALIB" / f"Camera{k}.cal")
        assert detect_up_axis(cam) == "+z", k
        assert detect_up_axis(cam, [read_mask(bt / f"FG{k}" / "image0000.bmp")]) == "+z", k


def test_up_axis_undecidable_is_one_error_asking_for_up(shared_data):
    """Camera 2 of sequenceB_2 is rolled on its side: alone, its orientation says y, the standing
    person's silhouette z; a camera tilted 45 degrees cannot say either. Both stop, naming --up."""
    from ipf_jax.data.silhouette import read_mask
    from ipf_jax.viz.synthetic import look_at_camera

    bt = shared_data("parsec_bodytrack/sequenceB_2")
    cam = read_calibration(bt / "CALIB" / "Camera2.cal")
    with pytest.raises(IPFError, match="--up"):
        detect_up_axis(cam, [read_mask(bt / "FG2" / "image0000.bmp")])
    tilted = look_at_camera(np.array([3.0, 0.0, 3.0]), np.array([0.0, 0.0, 0.0]), width=160,
                            height=120, focal_px=150)
    with pytest.raises(IPFError, match="give it with --up"):
        detect_up_axis([tilted])


def test_a_given_up_axis_is_contradicted_only_by_clear_evidence(shared_data):
    """--up's check: the other sign only when the cameras stand clearly on the other side of the
    floor, another axis only when the silhouettes lie along it; the rolled camera 2, which fools
    detection from its orientation, does not contradict the true +z."""
    from ipf_jax.data.silhouette import read_mask

    bt = shared_data("parsec_bodytrack/sequenceB_2")
    cams = read_calibration(bt / "CALIB")
    masks = [read_mask(bt / f"FG{k}" / "image0000.bmp") for k in (1, 2, 3, 4)]
    assert contradicted_up(cams, masks, "+z") is None
    assert contradicted_up(cams, masks, "-z") == "+z"  # upside down: the cameras are above +z
    assert contradicted_up(cams, masks, "+y") == "+z"  # the standing person lies along z
    assert contradicted_up(cams[1:2], masks[1:2], "+z") is None  # orientation says y: not clear
    assert contradicted_up(cams, None, "+x") is None  # no silhouettes: another axis never said


# --- projection against OpenCV -------------------------------------------------------------------

def points_in_image(cam, depths=(1.5, 3.0, 6.0)):
    """(N, 3) world points seen inside the image: a pixel grid back-projected at several depths.

    Pixels whose ray does not project back onto them are dropped: in the extreme corners of the
    strongly distorted uu images (cam1, cam4) the radial polynomial peaks below the corner radius,
    so no ray reaches them and OpenCV's polynomial folds back (where the model extends linearly).
    """
    u, v = np.meshgrid(np.linspace(5, cam.width - 6, 15), np.linspace(5, cam.height - 6, 11))
    px = np.stack([u.ravel(), v.ravel()], -1)
    crit = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-12)
    xn = cv2.undistortPoints(px[:, None], cam.K, cam.dist, None, None, None, crit).reshape(-1, 2)
    rays = np.c_[xn, np.ones(len(xn))]
    back = cv2.projectPoints(rays, np.zeros(3), np.zeros(3), cam.K, cam.dist)[0].reshape(-1, 2)
    rays = rays[np.abs(back - px).max(axis=1) < 1e-3]
    assert len(rays) > 0.9 * len(px), f"{cam.name}: too few pixels have a ray"
    Xc = np.concatenate([rays * d for d in depths])
    return (Xc - cam.T) @ cam.R  # camera to world


def opencv_uv(cam, X):
    rvec = cv2.Rodrigues(cam.R)[0]
    return cv2.projectPoints(X, rvec, cam.T, cam.K, cam.dist)[0].reshape(-1, 2)


N_POINTS = 3 * 15 * 11  # points_in_image's most points: one array shape, one compilation


@jax.jit
def _project_all(cams, X):
    return jax.vmap(lambda c, x: jcam.project_points(c, x)[0])(cams, X)


def jax_uv(cams, Xs):
    """The JAX projection of each camera's points (C cameras in one vmapped call)."""
    padded = np.stack([np.concatenate([X, np.repeat(X[:1], N_POINTS - len(X), 0)]) for X in Xs])
    uv = np.asarray(_project_all(jcam.stack_cameras(cams), jnp.asarray(padded, jnp.float32)))
    return [u[: len(X)].astype(float) for u, X in zip(uv, Xs)]


@pytest.mark.parametrize("which", ["bodytrack", "uu"])
def test_projection_matches_opencv(which, request):
    cams = request.getfixturevalue(f"{which}_cams")
    Xs = [points_in_image(cam) for cam in cams]
    for cam, X, uv_jax in zip(cams, Xs, jax_uv(cams, Xs)):
        uv_cv = opencv_uv(cam, X)
        err_np = np.abs(ref.project_points(cam, X)[0] - uv_cv).max()
        err_jax = np.abs(uv_jax - uv_cv).max()
        assert err_np < PIXEL_ATOL, f"{cam.name}: NumPy vs OpenCV {err_np:.2e} px"
        assert err_jax < PIXEL_ATOL, f"{cam.name}: JAX vs OpenCV {err_jax:.2e} px"


# --- bad input -----------------------------------------------------------------------------------

GOOD_CAL = ("584.24 583.31 332.08 228.58 0 -0.3173 0.1387 0 0 0 "
            "0.4109 -0.8514 0.3260 -0.6326 -0.0087 0.7745 -0.6565 -0.5245 -0.5421 "
            "206.1 -197.3 4524.5 -1.72 1.30 0.29")
XML = """<?xml version="1.0"?>
<opencv_storage>
<CameraMatrix type_id="opencv-matrix"><rows>{kr}</rows><cols>3</cols><dt>d</dt>
  <data>{K}</data></CameraMatrix>
<DistortionCoeffs type_id="opencv-matrix"><rows>1</rows><cols>5</cols><dt>d</dt>
  <data>-0.3 0.1 0 0 0</data></DistortionCoeffs>
<Rotation type_id="opencv-matrix"><rows>{rr}</rows><cols>{rc}</cols><dt>d</dt>
  <data>{R}</data></Rotation>
<Translation type_id="opencv-matrix"><rows>3</rows><cols>1</cols><dt>d</dt>
  <data>100. 200. 3000.</data></Translation>
</opencv_storage>
"""
K_OK = "490. 0. 330. 0. 490. 240. 0. 0. 1."
TOML = """[cam_a]
name = "a"
size = [ 640, 480]
matrix = {matrix}
distortions = [ 0.0, 0.0, 0.0, 0.0]
rotation = {rotation}
translation = [ 0.1, 0.2, 3.0]
fisheye = {fisheye}

[metadata]
adjusted = false
"""
MAT_OK = "[ [ 500.0, 0.0, 320.0], [ 0.0, 500.0, 240.0], [ 0.0, 0.0, 1.0]]"


def xml(K=K_OK, kr=3, R="0.1 0.2 0.3", rr=3, rc=1):
    return XML.format(K=K, kr=kr, R=R, rr=rr, rc=rc)


def toml(matrix=MAT_OK, rotation="[ 0.1, 0.2, 0.3]", fisheye="false"):
    return TOML.format(matrix=matrix, rotation=rotation, fisheye=fisheye)


BAD_FILES = {
    "cal_too_few_numbers": ("Camera1.cal", " ".join(GOOD_CAL.split()[:12]),
                            "expected 25 numbers .*found 12"),
    "cal_non_numeric": ("Camera1.cal", GOOD_CAL.replace("0.1387", "0.13x7"),
                        "non-numeric text '0.13x7'"),
    "cal_singular_rotation": ("Camera1.cal", re.sub(r"0\.4109 .* -0\.5421", " ".join(["0"] * 9),
                                                    GOOD_CAL), "not a proper rotation.*det 0"),
    "cal_not_orthonormal": ("Camera1.cal", GOOD_CAL.replace("0.4109", "0.9109"),
                            "not a proper rotation"),
    "xml_too_few_numbers": ("config.xml", xml(K="490. 0. 330. 0. 490. 240. 0."),
                            "CameraMatrix has 7 numbers, expected 9"),
    "xml_non_numeric": ("config.xml", xml(K=K_OK.replace("330.", "abc")),
                        "non-numeric text 'abc' in CameraMatrix"),
    "xml_singular_rotation": ("config.xml", xml(R="1 0 0 0 1 0 0 0 0", rc=3),
                              "not a proper rotation.*det 0"),
    "xml_wrong_matrix_shape": ("config.xml", xml(K="490. 0. 330. 0. 490. 240.", kr=2),
                               r"camera matrix has shape \(2, 3\), expected 3x3"),
    "xml_wrong_rotation_shape": ("config.xml", xml(R="0.1 0.2 0.3 0.4", rr=2, rc=2),
                                 r"rotation has shape \(2, 2\)"),
    "xml_malformed": ("config.xml", xml()[:150], "not a readable OpenCV XML/YAML file"),
    "xml_missing_node": ("config.xml", xml().replace("Translation", "Translaton"),
                         "missing Translation"),
    "toml_too_few_numbers": ("calib.toml", toml().replace("[ 0.1, 0.2, 3.0]", "[ 0.1, 0.2]"),
                             "translation has 2 numbers, expected 3"),
    "toml_ragged_matrix": ("calib.toml", toml(matrix="[ [ 500.0, 0.0, 320.0], [ 0.0, 1.0]]"),
                           r"camera \[cam_a\] matrix is ragged"),
    "toml_wrong_matrix_shape": ("calib.toml", toml(matrix="[ [ 500.0, 0.0], [ 0.0, 500.0]]"),
                                r"camera matrix has shape \(2, 2\), expected 3x3"),
    "toml_non_numeric": ("calib.toml", toml(rotation='[ 0.1, "x", 0.3]'),
                         r"camera \[cam_a\] rotation is non-numeric"),
    "toml_singular_rotation": ("calib.toml", toml(rotation="[[1, 0, 0], [0, 1, 0], [0, 0, 0]]"),
                               "not a proper rotation.*det 0"),
    "toml_fisheye": ("calib.toml", toml(fisheye="true"), "fisheye cameras are not supported"),
    "toml_syntax": ("calib.toml", toml().replace("size = [", "size = "),
                    "not a readable TOML calibration"),
    "json_not_json": ("cameras.json", '{"cameras": [', "not a readable JSON calibration"),
    "json_too_few_numbers": ("cameras.json", '{"cameras": [{"K": [[1, 0, 0], [0, 1, 0]], '
                             '"R": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "T": [0, 0, 1], '
                             '"width": 4, "height": 4}]}', "wrong shapes"),
    "unknown_format": ("calib.dat", "hello world", "unknown calibration format"),
}


@pytest.mark.parametrize("case", sorted(BAD_FILES))
def test_bad_calibration_names_file_and_problem(tmp_path, case):
    name, text, problem = BAD_FILES[case]
    path = tmp_path / name
    path.write_text(text)
    with pytest.raises(IPFError) as info:
        read_calibration(path, 640, 480)
    assert info.value.path == str(path)
    assert str(path) in str(info.value)
    assert re.search(problem, info.value.message), info.value.message


@pytest.mark.parametrize("name", ["Camera1.cal", "config.xml", "calib.yml", "calib.toml",
                                  "cameras.json"])
def test_missing_calibration_file(tmp_path, name):
    with pytest.raises(IPFError, match="not found") as info:
        read_calibration(tmp_path / name, 640, 480)
    assert info.value.path == str(tmp_path / name)


def test_folder_without_calibration(tmp_path):
    with pytest.raises(IPFError, match="no calibration in folder") as info:
        read_calibration(tmp_path)
    assert info.value.path == str(tmp_path)


def test_rational_distortion_terms_are_refused(tmp_path):
    path = tmp_path / "config.xml"
    path.write_text(xml().replace("<cols>5</cols>", "<cols>8</cols>")
                    .replace("-0.3 0.1 0 0 0", "-0.3 0.1 0 0 0 0.02 0 0"))
    with pytest.raises(IPFError, match="beyond k1 k2 p1 p2 k3 are non-zero"):
        read_calibration(path, 640, 480)


def test_frame_size_must_match_the_calibrated_size(sports2d_toml):
    with pytest.raises(IPFError, match="for 1768x994 images but the frames are 884x497"):
        read_calibration(sports2d_toml, 884, 497)


def test_bodytrack_reader_keeps_its_defaults(bodytrack_dir):
    cam = read_bodytrack_cal(bodytrack_dir / "CALIB" / "Camera3.cal")
    assert (cam.width, cam.height) == (640, 480)
    with pytest.raises(IPFError, match="calibration file not found"):
        read_json(bodytrack_dir / "nope.json")


def test_units_are_refused_where_the_format_fixes_them(bodytrack_dir):
    with pytest.raises(IPFError, match="units apply to OpenCV and TOML files only"):
        read_calibration(bodytrack_dir / "CALIB" / "Camera1.cal", units="m")


def test_two_cameras_of_one_name_are_refused_when_picked_by_name(tmp_path):
    """A dataset that picks its cameras by name: two of one name said 'Camera2 not in the
    calibration'. Taken in order, a calibration may repeat a name."""
    import json

    from ipf_jax.data.sources import _pair_cameras
    from ipf_jax.viz import synthetic as syn

    write_json(syn.ring_cameras(2, width=80, height=60, focal_px=75), tmp_path / "c.json")
    doc = json.loads((tmp_path / "c.json").read_text())
    doc["cameras"][1]["name"] = doc["cameras"][0]["name"]
    (tmp_path / "c.json").write_text(json.dumps(doc))
    cams = read_json(tmp_path / "c.json")  # in order: fine
    assert [c.name for c in cams] == ["Camera1", "Camera1"]
    assert _pair_cameras(cams, [{}, {}], tmp_path / "c.json") == cams
    with pytest.raises(IPFError, match="two cameras share the name Camera1"):
        _pair_cameras(cams, [{"name": "Camera1"}, {"name": "Camera2"}], tmp_path / "c.json")
