"""The factored filter's posture group (ipf_jax.filters.posture): the pelvis moved, the feet held."""
import jax
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ipf_jax.body import default_shape, load_limits
from ipf_jax.body.model import DOF_INDEX, DOF_NAMES, NUM_DOF
from ipf_jax.errors import IPFError
from ipf_jax.filters import posture, registry
from ipf_jax.geometry.posing import gait_pose
from ipf_jax.geometry.retarget import FEET, limb_points, retarget
from ipf_jax.geometry.world import up_rotation

FPS = 20.0
LIMITS = load_limits("default")
U = up_rotation("+z")
BODY = posture.Body(default_shape(1.75).values, U)
ARMS = [i for i, n in enumerate(DOF_NAMES) if "shoulder" in n or "elbow" in n]


def _crouch(hip_deg: float, knee_deg: float, pitch_deg: float) -> np.ndarray:
    """A pose bent at the hips and knees (both legs), the pelvis pitched, turned 30 deg."""
    q = gait_pose(hip_deg, knee_deg, hip_deg, knee_deg)
    q[DOF_INDEX["root_pitch"]] = np.deg2rad(pitch_deg)
    q[DOF_INDEX["root_yaw"]] = np.deg2rad(30.0)
    q[DOF_INDEX["root_tz"]] = 0.9
    return LIMITS.clip(q[None])[0]


@settings(max_examples=10, deadline=None)
@given(hip=st.floats(20, 70), knee=st.floats(40, 90), pitch=st.floats(-5, 20))
def test_children_keep_the_feet_and_move_the_pelvis_as_asked(hip, knee, pitch):
    # bent legs (a crouch, rising or sitting): every grid move is within their reach. A straight
    # leg cannot lift the pelvis with its foot held; there the retarget comes as near as it can
    kept = np.stack([_crouch(hip, knee, pitch), _crouch(0.7 * hip, 0.7 * knee, 0.0)])
    offsets = posture.grid(3, FPS)
    kids = posture.children(kept, offsets, BODY, LIMITS.clip)
    g = len(offsets)
    assert kids.shape == (2 * g, NUM_DOF) and np.all(LIMITS.clip(kids) == kids)
    centre = (g - 1) // 2
    assert np.all(offsets[centre] == 0)
    assert np.array_equal(kids[centre], kept[0]) and np.array_equal(kids[g + centre], kept[1])
    feet = limb_points(kept, np.broadcast_to(BODY.values, (2, len(BODY.values))), U, which=FEET)
    got = limb_points(kids, np.broadcast_to(BODY.values, (len(kids), len(BODY.values))), U, which=FEET)
    err = np.linalg.norm(got - np.repeat(feet, g, axis=0), axis=-1).max(-1)
    # the feet back within a tenth of a millimetre for most moves and within a few millimetres for
    # all, unless a leg reaches the end of a range (a knee straight under a pelvis lifted and moved
    # back); and never further than the pelvis move alone left them
    legs = [i for i, n in enumerate(DOF_NAMES) if n.startswith(("left_", "right_")) and i not in ARMS]
    lo, hi = np.asarray(LIMITS.lower)[legs], np.asarray(LIMITS.upper)[legs]
    free = ~np.any((kids[:, legs] <= lo + 1e-9) | (kids[:, legs] >= hi - 1e-9), axis=1)
    assert free.mean() > 0.8 and np.quantile(err[free], 0.9) < 1e-4 and err[free].max() < 5e-3, err
    unmoved = kids.copy()  # the same pelvis moves with the legs' angles kept
    unmoved[:, legs] = np.repeat(kept[:, legs], g, axis=0)
    before = np.linalg.norm(limb_points(unmoved, np.broadcast_to(BODY.values, (len(kids), len(BODY.values))),
                                        U, which=FEET) - np.repeat(feet, g, axis=0), axis=-1).max(-1)
    assert np.all(err <= before + 1e-9)
    # the pelvis moved by the offset: along the heading, along up, and in pitch
    fwd = np.repeat(posture.heading(kept, BODY), g, axis=0)
    off = np.tile(offsets, (2, 1))
    shift = kids[:, :3] - np.repeat(kept[:, :3], g, axis=0)
    assert np.allclose(shift @ U[:, 2], off[:, 1], atol=1e-12)
    assert np.allclose(np.einsum("ij,ij->i", shift, fwd), off[:, 0], atol=1e-12)
    pitch_moved = kids[:, DOF_INDEX["root_pitch"]] - np.repeat(kept[:, DOF_INDEX["root_pitch"]], g)
    assert np.allclose(pitch_moved, off[:, 2], atol=1e-12)
    assert np.array_equal(kids[:, ARMS], np.repeat(kept[:, ARMS], g, axis=0))  # the arms stay


def test_heading_is_the_pelvis_forward_axis_in_the_floor():
    q = _crouch(30, 40, 15)
    h = posture.heading(q[None], BODY)[0]
    assert np.allclose(h, [np.cos(np.deg2rad(30)), np.sin(np.deg2rad(30)), 0.0], atol=1e-12)


def test_retarget_of_the_feet_alone_moves_only_the_legs():
    kept = _crouch(40, 60, 10)[None]
    values = BODY.values[None]
    target = limb_points(kept, values, U, which=FEET)
    q = kept.copy()
    q[0, :3] += [0.03, 0.0, 0.02]  # the pelvis forward and up
    moved = retarget(q, values, target, U, LIMITS.clip, iterations=4, which=FEET)
    legs = [i for i, n in enumerate(DOF_NAMES) if n.startswith(("left_hip", "left_knee", "left_ankle",
                                                                  "right_hip", "right_knee", "right_ankle"))]
    others = [i for i in range(NUM_DOF) if i not in legs]
    assert np.array_equal(moved[:, others], q[:, others])
    before = np.linalg.norm(limb_points(q, values, U, which=FEET) - target, axis=-1).max()
    after = np.linalg.norm(limb_points(moved, values, U, which=FEET) - target, axis=-1).max()
    assert before > 0.02 and after < 1e-4


def test_the_filter_with_a_body_spends_the_budget_and_declares_its_calls():
    target = LIMITS.clip(np.full(NUM_DOF, 0.05)[None])[0]
    calls = []

    def measure(p):
        calls.append(len(p))
        return np.exp(-np.abs(p - target).sum(1))

    f = registry.make("fipf", {}, LIMITS, FPS, 6561, body=BODY)
    assert f.params["posture"] and f.params["stages"][:3] == ["root", "trunk", "posture"]
    # 7 groups (774 per kept particle for two rounds) and the posture's 27 a round: 828
    assert (f.params["top_m"], f.params["filler"], f.evaluations_per_frame) == (7, 6561 - 378 - 7 * 828, 6561)
    start = _crouch(20, 30, 5)[None]
    state = f.init(start, measure(start))
    calls.clear()
    state, info = f.step(jax.random.PRNGKey(0), state, measure)
    assert sum(calls) == info.evaluations == 6561 and tuple(calls) == f.calls
    assert info.best_weight >= float(measure(start)[0])
    off = registry.make("fipf", {"posture": False}, LIMITS, FPS, 6561, body=BODY)
    plain = registry.make("fipf", {}, LIMITS, FPS, 6561)  # no body: the groups alone, as before
    assert off.params == plain.params and not plain.params["posture"]


def test_the_posture_group_without_a_body_is_one_clear_error():
    with pytest.raises(IPFError, match="posture group needs the body"):
        registry.make("fipf", {"posture": True}, LIMITS, FPS, 6561)
