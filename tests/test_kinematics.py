"""Forward kinematics: JAX vs the NumPy reference, lengths, and anatomical directions."""
import jax
import numpy as np
import pytest

from ipf_jax.body import DOF_NAMES, default_shape, load_limits
from ipf_jax.body.model import POINT_INDEX
from ipf_jax.geometry import host as ref
from ipf_jax.geometry.kinematics import forward_kinematics
from ipf_jax.geometry.world import up_rotation
from ipf_jax.reference import GEOMETRY_ATOL_M

SHAPE = default_shape()
P = POINT_INDEX


def random_poses(n, seed=0):
    lim = load_limits("default")
    rng = np.random.default_rng(seed)
    q = rng.uniform(lim.lower, lim.upper, size=(n, len(DOF_NAMES)))
    q[:, :3] = rng.uniform(-2, 2, size=(n, 3))
    return q


def fk(q, up="+z"):
    return ref.forward_kinematics(q, SHAPE.values, up_rotation(up))


def test_jax_matches_reference_within_tolerance():
    q = random_poses(64)
    U = up_rotation("-y")
    batched = jax.jit(jax.vmap(forward_kinematics, in_axes=(0, None, None)))
    out = batched(q.astype(np.float32), SHAPE.values.astype(np.float32), U.astype(np.float32))
    for i in range(len(q)):
        r = ref.forward_kinematics(q[i], SHAPE.values, U)
        for name in ("points", "seg_a", "seg_b", "seg_r"):
            np.testing.assert_allclose(np.asarray(getattr(out, name)[i]), getattr(r, name),
                                       atol=GEOMETRY_ATOL_M, err_msg=f"field {name}, pose {i}")


def test_segment_lengths_are_rigid():
    for q in random_poses(20, seed=1):
        pts = fk(q).points
        assert np.linalg.norm(pts[P["left_knee"]] - pts[P["left_hip"]]) == pytest.approx(SHAPE["thigh"])
        assert np.linalg.norm(pts[P["right_ankle"]] - pts[P["right_knee"]]) == pytest.approx(SHAPE["shank"])
        assert np.linalg.norm(pts[P["left_wrist"]] - pts[P["left_elbow"]]) == pytest.approx(SHAPE["forearm"])


def test_neutral_pose_stands_upright_facing_x():
    pts = fk(np.zeros(31)).points
    z = pts[:, 2]
    assert z[P["head"]] > z[P["neck"]] > z[P["sacrum"]] > z[P["left_knee"]] > z[P["left_ankle"]]
    assert pts[P["left_hip"], 1] > 0 > pts[P["right_hip"], 1]  # left is +y
    assert pts[P["left_toe"], 0] > pts[P["left_ankle"], 0] > pts[P["left_heel"], 0]  # feet point +x


@pytest.mark.parametrize("dof, point, axis, sign", [
    ("left_hip_flexion", "left_knee", 0, +1),  # thigh forward
    ("right_knee_flexion", "right_ankle", 0, -1),  # shank backward
    ("left_ankle_dorsiflexion", "left_toe", 2, +1),  # toes up
    ("left_hip_abduction", "left_knee", 1, +1),  # away from the midline (left = +y)
    ("right_hip_abduction", "right_knee", 1, -1),
    ("left_shoulder_abduction", "left_elbow", 1, +1),
    ("right_shoulder_flexion", "right_elbow", 0, +1),
    ("left_elbow_flexion", "left_wrist", 0, +1),
    ("trunk_flexion", "neck", 0, +1),
    ("trunk_lateral", "neck", 1, +1),  # bends to the left
])
def test_positive_angles_move_anatomically(dof, point, axis, sign):
    q = np.zeros(31)
    base = fk(q).points[P[point]]
    q[DOF_NAMES.index(dof)] = np.deg2rad(20)
    moved = fk(q).points[P[point]]
    assert sign * (moved[axis] - base[axis]) > 0.01


def test_internal_rotation_turns_toes_medially_on_both_sides():
    for side, medial in (("left", -1), ("right", +1)):
        q = np.zeros(31)
        q[DOF_NAMES.index("left_knee_flexion" if side == "left" else "right_knee_flexion")] = 0.0
        base = fk(q).points[P[f"{side}_toe"], 1]
        q[DOF_NAMES.index(f"{side}_hip_rotation")] = np.deg2rad(30)
        assert medial * (fk(q).points[P[f"{side}_toe"], 1] - base) > 0.01


@pytest.mark.parametrize("up", ["+z", "-z", "+y", "-x"])
def test_up_axis_stands_the_body_up(up):
    from ipf_jax.geometry.world import axis_vector
    pts = fk(np.zeros(31), up).points
    a = axis_vector(up)
    assert pts[P["head"]] @ a - pts[P["left_ankle"]] @ a > 1.3


def test_yaw_turns_about_up():
    q = np.zeros(31)
    q[3] = np.pi / 2
    pts = fk(q).points
    assert pts[P["left_toe"], 1] > pts[P["left_heel"], 1]  # now facing +y
    assert pts[P["left_hip"], 0] < 0  # left side towards -x


def test_frame_axes_places_points_as_the_whole_forward_kinematics():
    """The partial forward kinematics of the tracking priors (only the frames asked for and their
    ancestors) places points where the whole tree does."""
    from ipf_jax.body.model import POINTS
    from ipf_jax.geometry.kinematics import frame_axes, place

    q = random_poses(50, seed=3)
    values = np.asarray(default_shape(1.7).values, float)
    up = up_rotation("-y")
    whole = forward_kinematics(q, values, up, xp=np).points
    wanted = [p for p in POINTS if p.frame in ("pelvis", "trunk", "left_shank", "right_forearm")]
    world = frame_axes(q.T, values, up, sorted({p.frame for p in wanted}))
    assert "head" not in world and "left_foot" not in world  # nothing beyond what was asked
    for p in wanted:
        got = np.stack(np.broadcast_arrays(*place(world, p.frame, p.position, values)), -1)
        np.testing.assert_allclose(got, whole[:, POINT_INDEX[p.name]], atol=1e-12)
    bodies = np.tile(values[:, None], (1, len(q)))  # a body per particle gives the same
    per = frame_axes(q.T, bodies, up, ["left_shank"])
    np.testing.assert_allclose(np.stack(place(per, "left_shank", (0, 0, "-shank"), bodies), -1),
                               whole[:, POINT_INDEX["left_ankle"]], atol=1e-12)


def test_the_trackers_joint_points_are_forward_kinematics_points_bit_for_bit():
    """``joint_points`` (the tracker's estimate every frame) places the points alone, with the same
    operations as :func:`forward_kinematics`: the same float64 numbers, not merely close ones."""
    U = up_rotation("-y")
    for q in random_poses(50, seed=3):
        whole = ref.forward_kinematics(q, SHAPE.values, U)
        assert np.array_equal(ref.joint_points(q, SHAPE.values, U), whole.points)
