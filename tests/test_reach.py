"""The factored filter's arms' reach search (ipf_jax.filters.reach): each arm over its whole range."""
import jax
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ipf_jax.body import default_shape, load_limits
from ipf_jax.body.model import NUM_DOF
from ipf_jax.errors import IPFError
from ipf_jax.filters import posture, reach, registry
from ipf_jax.geometry.posing import gait_pose
from ipf_jax.geometry.world import up_rotation

FPS = 20.0
LIMITS = load_limits("default")
BODY = posture.Body(default_shape(1.75).values, up_rotation("+z"))


def _peaked(arm: int, target_deg, calls: list, trap_deg=None):
    """A measure that depends only on one arm's four DOFs, highest (1) at ``target_deg``, a
    smooth bump 30 deg wide: what the search should climb whatever the start. With ``trap_deg``
    the bump is 8 deg wide and a second one, 20 deg wide and half as high, sits at the trap: a
    local optimum (an arm hanging where the person holds it forward)."""
    target = np.deg2rad(np.asarray(target_deg, float))
    dofs = list(reach.ARMS[arm])

    def bump(q, at, width):
        return np.exp(-((q[:, dofs] - at) ** 2).sum(1) / (2 * np.deg2rad(width) ** 2))

    def measure(q):
        calls.append(len(q))
        if trap_deg is None:
            return bump(q, target, 30.0)
        return bump(q, target, 8.0) + 0.5 * bump(q, np.deg2rad(np.asarray(trap_deg, float)), 20.0)
    return measure


@settings(max_examples=25, deadline=None)
@given(arm=st.sampled_from([0, 1]), flexion=st.floats(-40, 120), abduction=st.floats(-10, 60),
       rotation=st.floats(-60, 60), elbow=st.floats(0, 130))
def test_it_finds_an_arm_anywhere_in_its_range_and_moves_nothing_else(arm, flexion, abduction,
                                                                       rotation, elbow):
    start = gait_pose(20, 30, -10, 5)  # the arms hang straight: far from most targets
    calls = []
    particles, weights = reach.search(start, arm, _peaked(arm, (flexion, abduction, rotation, elbow), calls),
                                      LIMITS.clip)
    assert len(particles) == len(weights) == reach.cost() == sum(calls)
    assert tuple(calls) == reach.calls()
    found = particles[np.argmax(weights)]
    # the grid puts a start within ~25 deg of any arm pose, the sweeps (20, 10, 5, 2.5 deg, with
    # the combined moves) bring it within a few degrees
    err = np.rad2deg(np.abs(found[list(reach.ARMS[arm])] - np.deg2rad([flexion, abduction, rotation, elbow])))
    assert err.max() < 3.0, err
    # every particle is the start with that arm's DOFs changed only, inside the limits
    others = [i for i in range(NUM_DOF) if i not in reach.ARMS[arm]]
    assert np.array_equal(particles[:, others], np.broadcast_to(start[others], (len(particles), len(others))))
    assert np.array_equal(LIMITS.clip(particles), particles)


def test_the_filter_spends_the_budget_with_it_and_keeps_m():
    start = gait_pose(20, 30, -10, 5)[None]
    calls = []
    # the left forearm held forward, 60-90 deg from the hanging arm, which is a local optimum
    hanging = np.rad2deg(start[0, list(reach.ARMS[0])])
    measure = _peaked(0, (60.0, 10.0, 0.0, 90.0), calls, trap_deg=hanging)
    f = registry.make("fipf", {"reach": True}, LIMITS, FPS, 6561, body=BODY)
    assert f.params["reach"] and f.params["reach_cost"] == reach.cost() == 180
    # the same M as without it: 7 x 828 + the polish's 378 + 180 leaves a filler of 207
    assert (f.params["top_m"], f.params["filler"], f.evaluations_per_frame) == (7, 207, 6561)
    state = f.init(start, measure(start))
    best = []
    for frame in range(6):  # one arm a frame, drawn: the left one within a few frames
        calls.clear()
        state, info = f.step(jax.random.PRNGKey(frame), state, measure)
        assert sum(calls) == info.evaluations == 6561 and tuple(calls) == f.calls
        best.append(info.best_weight)
    # the reach search finds it on the first frame that draws the left arm (the polish after it
    # refines the best); the groups' few degrees a frame stay in the trap
    assert max(best) > 0.99, best
    off = registry.make("fipf", {}, LIMITS, FPS, 6561, body=BODY)
    off_state = off.init(start, measure(start))
    for frame in range(6):
        off_state, info = off.step(jax.random.PRNGKey(frame), off_state, measure)
    assert info.best_weight < 0.51
    assert not off.params["reach"] and off.params["reach_cost"] == 0 and off.params["filler"] == 387


def test_the_camera_rule_gives_way_to_a_small_budget_but_an_asked_search_does_not():
    # by the number of cameras (the tracker gives it): on from reach.MIN_VIEWS
    assert not registry.resolve("fipf", {}, FPS, 6561, views=reach.MIN_VIEWS - 1).reach
    assert registry.resolve("fipf", {}, FPS, 6561, views=reach.MIN_VIEWS).reach
    # a budget too small for it drops it with the polish, unless asked for: then one clear error
    small = registry.resolve("fipf", {"points_per_dof": 2}, FPS, 300, views=4)
    assert not small.reach and small.polish == 0 and small.evaluations() == 300
    with pytest.raises(IPFError, match="reach search 180"):
        registry.resolve("fipf", {"points_per_dof": 2, "reach": True}, FPS, 300, views=4)
