"""Pose transfer between bodies (ipf_jax.geometry.retarget): the limb joints stay in place."""
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from ipf_jax.body import default_shape, load_limits
from ipf_jax.body import proportions as P
from ipf_jax.geometry.posing import gait_pose
from ipf_jax.geometry.retarget import limb_points, retarget
from ipf_jax.geometry.world import up_rotation
from ipf_jax.tracking.shape_fit import place_on_floor_many

U = up_rotation("+z")
LIMITS = load_limits("default")


def _carry(q, old, new, iterations):
    """Poses fitted with body ``old`` carried to body ``new`` as the shape fit does: on the floor,
    the limb angles moved (``iterations`` > 0), on the floor again."""
    n = len(q)
    o, v = np.broadcast_to(old, (n, len(old))), np.broadcast_to(new, (n, len(new)))
    targets = limb_points(place_on_floor_many(q, o, U), o, U)
    placed = place_on_floor_many(q, v, U)
    if iterations:
        moved = retarget(placed, v, targets, U, LIMITS.clip, iterations=iterations)
        placed = place_on_floor_many(moved, v, U)
    legs = [0, 1, 2, 3, 6, 7, 8, 9]  # knees, ankles, heels, toes (the arms may be out of reach)
    return np.linalg.norm(limb_points(placed, v, U) - targets, axis=-1)[:, legs].mean(-1), placed


def test_the_same_body_keeps_the_pose():
    q = np.stack([gait_pose(25, 5, -10, 10), gait_pose(-5, 5, 20, 50)])
    body = default_shape(1.8).values
    err, placed = _carry(q, body, body, 3)
    assert np.allclose(placed, place_on_floor_many(q, np.broadcast_to(body, (2, len(body))), U), atol=1e-9)
    assert np.all(err < 1e-9)


@settings(max_examples=12, deadline=None)
@given(hip=st.floats(-15, 30), knee=st.floats(5, 60), thigh=st.floats(0.87, 1.0),
       trunk=st.floats(1.0, 1.13))
def test_a_shorter_thigh_under_a_longer_trunk_keeps_the_knees_and_feet(hip, knee, thigh, trunk):
    # the heavy render's case (docs/shape_fit.md): the hips come down, the knees and feet stay.
    # A straight knee (0 deg) is left out: at its limit a shorter thigh under an extended hip
    # cannot reach the old knee and foot (up to 11 mm left, 0.04 mm worse than the angles alone)
    ref = default_shape(1.85).values
    theta = np.zeros(P.NUM_GROUPS)
    for name, f in (("thigh", thigh), ("trunk", trunk)):
        theta[P.GROUP_NAMES.index(name)] = np.log(f)
    new = P.build(ref, theta)
    q = np.stack([gait_pose(hip, knee, -0.5 * hip, 5), gait_pose(-0.5 * hip, 5, hip, knee)])
    kept, _ = _carry(q, ref, new, 0)
    moved, placed = _carry(q, ref, new, 3)
    assert np.all(moved <= kept + 1e-6)
    assert np.all(moved <= 0.5 * kept + 2e-3), (kept, moved)  # halved, or within 2 mm
    assert np.all(LIMITS.clip(placed) == placed)


def test_limb_points_are_forward_kinematics_number_for_number():
    """The retarget's own placement of the kept joints (only their frames turned) gives the float64
    numbers of the full forward kinematics exactly, for poses and bodies with leading axes."""
    from ipf_jax.geometry.kinematics import forward_kinematics
    from ipf_jax.geometry.retarget import KEPT_POINTS

    rng = np.random.default_rng(4)
    base = default_shape(1.75).values
    q = np.stack([gait_pose(a, 5, b, c) for a, b, c in rng.uniform(-30, 40, (6, 3))]).reshape(2, 3, -1)
    q = q + rng.normal(0, 0.05, q.shape)
    bodies = base * rng.uniform(0.9, 1.1, (2, 3, len(base)))
    full = forward_kinematics(q, np.moveaxis(bodies, -1, 0)[..., None], U, xp=np).points[..., KEPT_POINTS, :]
    got = limb_points(q, bodies, U)
    assert got.shape == (2, 3, len(KEPT_POINTS), 3)
    assert np.array_equal(got, full)
    one = limb_points(q, base, U)  # one body for every pose
    assert np.array_equal(one, forward_kinematics(q, base, U, xp=np).points[..., KEPT_POINTS, :])
    tilted = up_rotation("-y") @ up_rotation("+z")  # a root rotation that is not the identity
    full = forward_kinematics(q, np.moveaxis(bodies, -1, 0)[..., None], tilted, xp=np).points
    assert np.array_equal(limb_points(q, bodies, tilted), full[..., KEPT_POINTS, :])


def _retarget_full(q, values, targets, U, clip, iterations=3, step=1e-3, damping=1e-4):
    """The retarget as first written: every kept joint placed for every DOF's step, by the full
    forward kinematics (the reference the limb-by-limb Jacobian must equal)."""
    from ipf_jax.geometry.kinematics import forward_kinematics
    from ipf_jax.geometry.retarget import KEPT_POINTS, LIMB_DOFS

    q = np.array(q, np.float64)
    n, k = q.shape[0], len(LIMB_DOFS)
    v = np.repeat(np.asarray(values, np.float64)[:, None], k + 1, 1)
    for _ in range(iterations):
        qq = np.repeat(q[:, None], k + 1, 1)
        qq[:, 1:, LIMB_DOFS] += step * np.eye(k)
        p = forward_kinematics(qq, np.moveaxis(v, -1, 0)[..., None], U, xp=np).points[..., KEPT_POINTS, :]
        residual = (p[:, 0] - targets).reshape(n, -1, 1)
        J = ((p[:, 1:] - p[:, :1]) / step).reshape(n, k, -1)
        delta = np.linalg.solve(J @ J.transpose(0, 2, 1) + damping * np.eye(k), -(J @ residual))
        q[:, LIMB_DOFS] += delta[..., 0]
        q = clip(q)
    return q


def test_the_limb_by_limb_jacobian_gives_the_full_one_number_for_number():
    """The retarget places each limb's joints alone for its DOFs' steps: the same float64 poses as
    placing every kept joint for every step (whose other differences were exactly zero)."""
    rng = np.random.default_rng(9)
    base = default_shape(1.8).values
    q = np.stack([gait_pose(a, 5, b, c) for a, b, c in rng.uniform(-30, 40, (5, 3))])
    bodies = base * rng.uniform(0.9, 1.1, (5, len(base)))
    targets = limb_points(q, base, U) + rng.normal(0, 0.02, (5, 12, 3))
    got = retarget(q, bodies, targets, U, LIMITS.clip)
    assert np.array_equal(got, _retarget_full(q, bodies, targets, U, LIMITS.clip))
    assert not np.array_equal(got, q)  # it did move them
