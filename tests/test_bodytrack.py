"""PARSEC bodytrack interoperability: readers, its kinematics checked against its own images, fit."""
from __future__ import annotations

import itertools

import numpy as np
import pytest

from ipf_jax.analysis.bodytrack import (
    PART_NAMES,
    POINT_NAMES,
    SHARED_JOINTS,
    agreement,
    axis_samples,
    bodytrack_geometry,
    bodytrack_points,
    bodytrack_points_batch,
    cone_outlines,
    euler_zxy,
    fg_fraction,
    fg_hits,
    fit_our_pose,
    mean_joint_distance,
    peer_joints,
    read_body_shape,
    read_fg_mask,
    read_overlay,
    read_pose,
    render_overlay,
)
from ipf_jax.analysis.bodytrack.overlay import draw_outlines
from ipf_jax.body import default_shape, load_limits
from ipf_jax.body.model import DOF_INDEX, POINT_INDEX
from ipf_jax.data.calibration import read_bodytrack_cal
from ipf_jax.errors import IPFError
from ipf_jax.geometry.host import forward_kinematics, project_points
from ipf_jax.geometry.world import up_rotation

PEER = "bodytrack_poses_sequenceB_2_4cams_2frames_4000p_5layers_serial.txt"
LENGTH_TOL = 1e-9  # metres: cone lengths are exact up to float64 rounding


# --------------------------------------------------------------------------------------------------
# fixtures

@pytest.fixture(scope="module")
def seq(bodytrack_dir):
    return bodytrack_dir


@pytest.fixture(scope="module")
def peer_dir(shared_data):
    return shared_data("parsec_bodytrack")


@pytest.fixture(scope="module")
def shape(seq):
    return read_body_shape(seq / "BodyShapeParameters.txt")


@pytest.fixture(scope="module")
def cams(seq):
    return [read_bodytrack_cal(seq / "CALIB" / f"Camera{k}.cal") for k in range(1, 5)]


@pytest.fixture(scope="module")
def masks(seq):
    return {f: [read_fg_mask(seq / f"FG{k}" / f"image{f:04d}.bmp") for k in range(1, 5)]
            for f in (0, 1)}


@pytest.fixture(scope="module")
def initial(seq):
    return read_pose(seq / "InitialPose.txt")[0]


@pytest.fixture(scope="module")
def peer(peer_dir):
    return read_pose(peer_dir / PEER)


def _turned(pose, angle):
    """The same pose turned about the world's vertical through the pelvis (E's Rz is leftmost)."""
    p = pose.copy()
    p[2] += angle
    return p


# --------------------------------------------------------------------------------------------------
# readers

def test_read_pose_files(seq, peer_dir):
    init = read_pose(seq / "InitialPose.txt")  # one line, trailing space, CRLF, blank last line
    assert init.shape == (1, 31)
    assert init[0, 3] == pytest.approx(134.693) and init[0, 30] == pytest.approx(0.383283)
    poses = read_pose(peer_dir / PEER)
    assert poses.shape == (2, 31) and np.all(np.isfinite(poses))


@pytest.mark.parametrize("text, problem", [
    ("1 2 3\r\n", "expected 31 numbers"),
    (" ".join(["0"] * 30) + " x\r\n", "non-numeric"),
    (" ".join(["0"] * 30) + " nan\r\n", "non-finite"),
    ("\r\n \r\n", "no pose"),
])
def test_read_pose_rejects_bad_files(tmp_path, text, problem):
    path = tmp_path / "poses.txt"
    path.write_bytes(text.encode())
    with pytest.raises(IPFError, match=problem) as err:
        read_pose(path)
    assert err.value.path == str(path)


def test_read_pose_missing_file(tmp_path):
    with pytest.raises(IPFError, match="not found"):
        read_pose(tmp_path / "nope.txt")


def test_read_body_shape(shape, tmp_path):
    assert shape.limbs.shape == (10, 4) and shape.lengths.shape == (18,)
    assert shape.limbs[0, 0] == pytest.approx(160.0) and shape.limbs[9, 3] == pytest.approx(0.7396, abs=1e-4)
    assert shape.lengths[0] == pytest.approx(578.571268037074)
    assert shape.lengths[17] == pytest.approx(268.030179506415)
    bad = tmp_path / "BodyShapeParameters.txt"
    bad.write_text("1\n" * 57)
    with pytest.raises(IPFError, match="expected 58 numbers"):
        read_body_shape(bad)


# --------------------------------------------------------------------------------------------------
# kinematics: internal facts

def test_euler_zxy_order():
    a, b, c = 0.3, -0.7, 1.1
    rx = np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])
    ry = np.array([[np.cos(b), 0, np.sin(b)], [0, 1, 0], [-np.sin(b), 0, np.cos(b)]])
    rz = np.array([[np.cos(c), -np.sin(c), 0], [np.sin(c), np.cos(c), 0], [0, 0, 1]])
    np.testing.assert_allclose(euler_zxy(a, b, c), rz @ rx @ ry, atol=1e-15)


@pytest.mark.parametrize("which", ["initial", "peer0", "peer1"])
def test_limb_lengths_match_shape_file(which, initial, peer, shape):
    pose = {"initial": initial, "peer0": peer[0], "peer1": peer[1]}[which]
    p = bodytrack_points(pose, shape)
    L = shape.lengths * 1e-3
    expected = {
        ("left_hip", "left_knee"): L[2], ("left_knee", "left_ankle"): L[3],
        ("right_hip", "right_knee"): L[6], ("right_knee", "right_ankle"): L[7],
        ("left_shoulder", "left_elbow"): L[10], ("left_elbow", "left_wrist"): L[11],
        ("right_shoulder", "right_elbow"): L[14], ("right_elbow", "right_wrist"): L[15],
        ("sacrum", "left_hip"): L[1], ("sacrum", "right_hip"): L[5],
        ("neck", "left_shoulder"): L[9], ("neck", "right_shoulder"): L[13],
        ("head", "head_top"): L[17], ("sacrum", "neck"): L[0],
    }
    for (a, b), length in expected.items():
        assert abs(np.linalg.norm(p[a] - p[b]) - length) < LENGTH_TOL, (a, b)
    geo = bodytrack_geometry(pose, shape)
    for i, name in enumerate(PART_NAMES):
        assert np.linalg.norm(geo.parts.b[i] - geo.parts.a[i]) == pytest.approx(
            abs(geo.parts.length[i]), abs=LENGTH_TOL), name


def test_cone_ends_are_the_named_points(initial, shape):
    geo = bodytrack_geometry(initial, shape)
    p = dict(zip(POINT_NAMES, geo.points))
    ends = {"left_thigh": ("left_hip", "left_knee"), "left_shin": ("left_knee", "left_ankle"),
            "right_thigh": ("right_hip", "right_knee"), "right_shin": ("right_knee", "right_ankle"),
            "left_upper_arm": ("left_shoulder", "left_elbow"),
            "left_forearm": ("left_elbow", "left_wrist"),
            "right_upper_arm": ("right_shoulder", "right_elbow"),
            "right_forearm": ("right_elbow", "right_wrist"), "head": ("head", "head_top")}
    for part, (a, b) in ends.items():
        i = PART_NAMES.index(part)
        np.testing.assert_allclose(geo.parts.a[i], p[a], atol=1e-12, err_msg=part)
        np.testing.assert_allclose(geo.parts.b[i], p[b], atol=1e-12, err_msg=part)
    np.testing.assert_allclose(geo.parts.a[0], p["sacrum"], atol=1e-12)


def test_batch_matches_single(peer, shape):
    batch = bodytrack_points_batch(peer, shape)
    assert batch.shape == (2, len(POINT_NAMES), 3)
    for f in range(2):
        single = bodytrack_points(peer[f], shape)
        np.testing.assert_array_equal(batch[f], np.stack([single[n] for n in POINT_NAMES]))


def test_standing_subject_is_plausible(initial, shape):
    p = bodytrack_points(initial, shape)
    # world metres, Z up, floor at 0: ankles near the floor, head on top
    assert p["left_ankle"][2] < 0.1 and p["right_ankle"][2] < 0.1
    assert 1.5 < p["head_top"][2] < 1.9
    assert p["neck"][2] > p["sacrum"][2] > p["left_knee"][2]


# --------------------------------------------------------------------------------------------------
# kinematics against the images

def test_pelvis_projects_inside_every_mask(initial, cams, masks):
    pelvis = initial[3:6] * 1e-3
    for cam, mask in zip(cams, masks[0]):
        assert fg_hits(pelvis, cam, mask), cam.name


@pytest.mark.parametrize("which, frame", [("initial", 0), ("peer0", 0), ("peer1", 1)])
def test_body_lies_on_the_foreground(which, frame, initial, peer, shape, cams, masks):
    pose = {"initial": initial, "peer0": peer[0], "peer1": peer[1]}[which]
    good = fg_fraction(bodytrack_geometry(pose, shape).parts, cams, masks[frame])
    turned = fg_fraction(bodytrack_geometry(_turned(pose, np.pi / 2), shape).parts, cams, masks[frame])
    shifted = pose.copy()
    shifted[3] += 400.0  # 40 cm sideways
    moved = fg_fraction(bodytrack_geometry(shifted, shape).parts, cams, masks[frame])
    # measured: 0.95..0.99 for the three real poses; 0.67 turned by 90 deg
    assert good > 0.9, good
    assert turned < good - 0.2, (good, turned)
    assert moved < good - 0.2, (good, moved)


def test_left_is_the_subjects_left(initial, shape, cams, masks):
    """Both feet reach out along the pelvis +x from the ankles, so +x is forward and +y (left) is
    the anatomical left (the calibration's world frame is right-handed)."""
    geo = bodytrack_geometry(initial, shape)
    fwd = geo.parts.frames[0][:3, 0].copy()
    fwd[2] = 0.0
    fwd /= np.linalg.norm(fwd)
    p = dict(zip(POINT_NAMES, geo.points))
    d = np.linspace(0.06, 0.2, 8)[:, None]
    for side in ("left", "right"):
        ahead, behind = p[f"{side}_ankle"] + d * fwd, p[f"{side}_ankle"] - d * fwd
        ahead[:, 2] = behind[:, 2] = 0.04  # foot height
        hit_ahead = np.mean([fg_hits(ahead, c, m) for c, m in zip(cams, masks[0])])
        hit_behind = np.mean([fg_hits(behind, c, m) for c, m in zip(cams, masks[0])])
        assert hit_ahead > hit_behind + 0.25, (side, hit_ahead, hit_behind)  # 0.88/0.44, 0.75/0.34


@pytest.fixture(scope="module")
def overlays(peer_dir):
    return [read_overlay(peer_dir / "bodytrack_outputs" / f"Result{f:04d}.bmp") for f in (0, 1)]


def _corners(pose, shape, cams):
    parts = bodytrack_geometry(pose, shape).parts
    return np.stack([cone_outlines(parts, c) for c in cams])  # (C, 10, 4, 2)


@pytest.mark.parametrize("frame", [0, 1])
def test_overlay_redrawn_pixel_for_pixel(frame, peer, shape, cams, overlays):
    """Our projection of bodytrack's estimate, drawn like its OutputBMP, is its Result image."""
    ours = render_overlay(_corners(peer[frame], shape, cams))
    same = agreement(ours, overlays[frame], tol=0)
    other = agreement(ours, overlays[1 - frame], tol=0)
    assert same.exact > 0.99, same  # measured 1.0 (every drawn pixel, colour included)
    assert other.exact < 0.5, other  # the other frame's estimate: 0.32


def test_overlay_quadrants_are_cameras_in_order(peer, shape, cams, overlays):
    corners = _corners(peer[0], shape, cams)
    theirs = overlays[0]
    score = np.zeros((4, 4))  # [quadrant, camera]
    for q, c in itertools.product(range(4), range(4)):
        ox, oy = (q % 2) * 320, (q // 2) * 240
        ours = np.zeros_like(theirs)
        draw_outlines(corners[c], ours, (ox, oy), (320, 240))
        view = (slice(oy, oy + 240), slice(ox, ox + 320))
        score[q, c] = agreement(ours[view], theirs[view], tol=0).exact
    totals = {perm: sum(score[q, c] for q, c in enumerate(perm))
              for perm in itertools.permutations(range(4))}
    assert max(totals, key=totals.get) == (0, 1, 2, 3)
    assert np.all(np.diag(score) > 0.99) and np.all(score[~np.eye(4, dtype=bool)] < 0.1), score


def test_overlay_tells_left_from_right(peer, shape, cams, overlays):
    """Swapping the colours of left and right parts breaks the match: the sides are bodytrack's."""
    ours = render_overlay(_corners(peer[0], shape, cams))
    swapped = ours.copy()
    swapped[ours == 1], swapped[ours == 2] = 2, 1
    assert agreement(swapped, overlays[0], tol=0).exact < 0.7


def test_axis_samples_span_the_cones(initial, shape):
    parts = bodytrack_geometry(initial, shape).parts
    s = axis_samples(parts, 5)
    assert s.shape == (10, 5, 3)
    np.testing.assert_allclose(s[:, 0], parts.a)
    np.testing.assert_allclose(s[:, -1], parts.b)


# --------------------------------------------------------------------------------------------------
# comparison helpers and the fit of our body

def test_peer_joints_and_distance(seq, peer_dir, peer, shape):
    joints, names = peer_joints(peer_dir / PEER, seq / "BodyShapeParameters.txt")
    assert joints.shape == (2, len(names), 3) and names == POINT_NAMES
    d01 = mean_joint_distance(joints[0], joints[1], ours_names=names)
    assert 0.0 < d01 < 0.05  # two consecutive frames of a nearly still subject
    assert mean_joint_distance(joints, joints, ours_names=names) == 0.0
    as_dict = bodytrack_points(peer[0], shape)
    assert mean_joint_distance(as_dict, joints[0]) == 0.0
    with pytest.raises(IPFError, match="missing"):
        mean_joint_distance({"left_hip": np.zeros(3)}, joints[0])


def test_fit_recovers_our_own_pose():
    """A body of our own model at a known pose and height is fitted back to within 1 mm."""
    U = up_rotation("+z")
    q = np.zeros(31)
    q[:3] = (0.5, -1.0, 0.95)
    q[DOF_INDEX["root_yaw"]] = 2.5
    for name, deg in [("left_hip_flexion", 20), ("left_knee_flexion", 30), ("right_hip_flexion", -10),
                      ("right_knee_flexion", 10), ("left_shoulder_flexion", 30),
                      ("left_elbow_flexion", 45), ("right_shoulder_abduction", 20),
                      ("right_elbow_flexion", 20), ("trunk_rotation", 10)]:
        q[DOF_INDEX[name]] = np.radians(deg)
    shape = default_shape(1.62)
    pts = forward_kinematics(q, shape.values, U).points
    fit = fit_our_pose({n: pts[POINT_INDEX[n]] for n in SHARED_JOINTS})
    assert fit.rms_m < 1e-3, fit.rms_m
    assert fit.height_m == pytest.approx(1.62, abs=0.01)


def test_fit_our_body_to_initial_pose(initial, shape):
    target = bodytrack_points(initial, shape)
    fit = fit_our_pose(target)
    lim = load_limits("default")
    assert fit.q.shape == (31,)
    assert np.all(fit.q >= lim.lower - 1e-9) and np.all(fit.q <= lim.upper + 1e-9)
    # measured: RMS 4.4 cm at 1.80 m (bodytrack's upper arms are 6-8 cm shorter than ours)
    assert fit.rms_m < 0.06, fit.rms_m
    assert 1.6 < fit.height_m < 2.0, fit.height_m
    assert mean_joint_distance(fit.points, target) < 0.05
    np.testing.assert_allclose(fit.points[POINT_INDEX["left_knee"]], target["left_knee"], atol=0.03)


def test_fit_rejects_unknown_joint(initial, shape):
    with pytest.raises(IPFError, match="head_top"):
        fit_our_pose(bodytrack_points(initial, shape), joints=("left_hip", "head_top"))


def test_outline_corners_lie_near_the_axis_projection(initial, shape, cams):
    """Each outline's side midpoints straddle the projected cone axis (sanity of the quad)."""
    parts = bodytrack_geometry(initial, shape).parts
    for cam in cams:
        c = cone_outlines(parts, cam)
        a = project_points(cam, parts.a)[0]
        b = project_points(cam, parts.b)[0]
        np.testing.assert_allclose((c[:, 0] + c[:, 3]) / 2, a, atol=1.5)
        np.testing.assert_allclose((c[:, 1] + c[:, 2]) / 2, b, atol=1.5)
