"""The factored filter's arms' reach search (ipf_jax.filters.reach): each arm over its whole range."""
import jax
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from ipf_jax.body import default_shape, load_limits
from ipf_jax.body.model import NUM_DOF
from ipf_jax.filters import posture, reach, registry
from ipf_jax.geometry.posing import gait_pose
from ipf_jax.geometry.world import up_rotation

FPS = 20.0
LIMITS = load_limits("default")
BODY = posture.Body(default_shape(1.75).values, up_rotation("+z"))


def _peaked(arm: int, target_deg, calls: list):
    """A measure that depends only on one arm's four DOFs, highest at ``target_deg`` (a smooth
    bump 30 deg wide): what the search should climb whatever the start."""
    target = np.deg2rad(np.asarray(target_deg, float))
    dofs = list(reach.ARMS[arm])

    def measure(q):
        calls.append(len(q))
        return np.exp(-((q[:, dofs] - target) ** 2).sum(1) / (2 * np.deg2rad(30.0) ** 2))
    return measure


@settings(max_examples=25, deadline=None)
@given(arm=st.sampled_from([0, 1]), flexion=st.floats(-40, 120), abduction=st.floats(-10, 60),
       rotation=st.floats(-60, 60), elbow=st.floats(0, 130))
def test_it_finds_an_arm_anywhere_in_its_range_and_moves_nothing_else(arm, flexion, abduction,
                                                                       rotation, elbow):
    start = gait_pose(20, 30, -10, 5)  # the arms hang straight: far from most targets
    calls = []
    particles, weights = reach.search(start, _peaked(arm, (flexion, abduction, rotation, elbow), calls),
                                      LIMITS.clip)
    assert len(particles) == len(weights) == reach.cost() == sum(calls)
    assert tuple(calls) == reach.calls()
    found = particles[np.argmax(weights)]
    # the grid puts a start within ~25 deg of any arm pose, the sweeps (20, 10, 5, 2.5 deg, with
    # the combined moves) bring it within a few degrees
    err = np.rad2deg(np.abs(found[list(reach.ARMS[arm])] - np.deg2rad([flexion, abduction, rotation, elbow])))
    assert err.max() < 3.0, err
    # every particle is the start with one arm's DOFs changed, inside the limits
    for p in particles:
        changed = set(np.flatnonzero(p != start))
        assert any(changed <= set(dofs) for dofs in reach.ARMS), changed
    assert np.array_equal(LIMITS.clip(particles), particles)


def test_the_filter_spends_the_budget_with_it_and_keeps_m():
    start = gait_pose(20, 30, -10, 5)[None]
    calls = []
    measure = _peaked(0, (60.0, 10.0, 0.0, 90.0), calls)  # the left forearm held forward
    f = registry.make("fipf", {"reach": True}, LIMITS, FPS, 6561, body=BODY)
    assert f.params["reach"] and f.params["reach_cost"] == reach.cost() == 360
    # the same M as without it: 7 x 828 + the polish's 378 + 360 leaves a filler of 27
    assert (f.params["top_m"], f.params["filler"], f.evaluations_per_frame) == (7, 27, 6561)
    state = f.init(start, measure(start))
    calls.clear()
    state, info = f.step(jax.random.PRNGKey(0), state, measure)
    assert sum(calls) == info.evaluations == 6561 and tuple(calls) == f.calls
    # a held-forward forearm is 60-90 deg from the hanging arm: the groups' few degrees a frame
    # cannot reach it, the reach search does (the polish after it refines the best)
    assert info.best_weight > 0.99
    off = registry.make("fipf", {}, LIMITS, FPS, 6561, body=BODY)
    assert not off.params["reach"] and off.params["reach_cost"] == 0 and off.params["filler"] == 387
