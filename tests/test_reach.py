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


#: The widths (deg) of an arm's basin in the renders' weights, shoulder flexion, abduction,
#: rotation and elbow flexion: the weight falls by about a seventh 2.5 deg from the true upper
#: arm and 10-20 deg from the true forearm (docs/fipf.md)
BASIN_DEG = np.array([6.0, 6.0, 12.0, 25.0])


def _peaked(arm: int, target_deg, calls: list, trap_deg=None):
    """A measure that depends only on one arm's four DOFs, highest (1) at ``target_deg``, a
    smooth bump 30 deg wide: what the search should climb whatever the start. With ``trap_deg``
    it is shaped like the renders' weights instead: a plateau (the rest of the body, 0.5) with
    two narrow basins (:data:`BASIN_DEG`), the true arm's (1) and the trap's (0.9: the arm the
    track holds, a local optimum), in each of which the upper arm scores on its own and the
    forearm only with it."""
    target = np.deg2rad(np.asarray(target_deg, float))
    dofs = list(reach.ARMS[arm])

    def bump(q, at, width):
        return np.exp(-((q[:, dofs] - at) ** 2).sum(1) / (2 * np.deg2rad(width) ** 2))

    def basin(q, at):
        d2 = ((q[:, dofs] - at) / np.deg2rad(BASIN_DEG)) ** 2
        return 0.25 * np.exp(-d2[:, :2].sum(1) / 2) * (1 + np.exp(-d2[:, 2:].sum(1) / 2))

    def measure(q):
        calls.append(len(q))
        if trap_deg is None:
            return bump(q, target, 30.0)
        trap = np.deg2rad(np.asarray(trap_deg, float))
        return 0.5 + np.maximum(basin(q, target), 0.8 * basin(q, trap))
    return measure


@settings(max_examples=25, deadline=None)
@given(arm=st.sampled_from([0, 1]), flexion=st.floats(-30, 100), abduction=st.floats(0, 40),
       rotation=st.floats(-40, 40), elbow=st.floats(10, 130))
def test_it_finds_an_arm_anywhere_in_its_range_and_moves_nothing_else(arm, flexion, abduction,
                                                                       rotation, elbow):
    start = gait_pose(20, 30, -10, 5)  # the arms hang straight: far from most targets
    calls = []
    particles, weights = reach.search(start, arm, _peaked(arm, (flexion, abduction, rotation, elbow), calls),
                                      LIMITS.clip)
    assert len(particles) == len(weights) == reach.cost() == sum(calls)
    assert tuple(calls) == reach.calls()
    found = particles[np.argmax(weights)]
    # anywhere in the grids' box: the upper arm's grid and the forearm's put a start within 7-30
    # deg of it, the sweeps (10, 6, 4, 2, 1 deg, with the combined moves) bring it within 2 deg
    # (1.29 at most over 1,500 random arms when this was written)
    err = np.rad2deg(np.abs(found[list(reach.ARMS[arm])] - np.deg2rad([flexion, abduction, rotation, elbow])))
    assert err.max() < 2.0, err
    # every particle is the start with that arm's DOFs changed only, inside the limits
    others = [i for i in range(NUM_DOF) if i not in reach.ARMS[arm]]
    assert np.array_equal(particles[:, others], np.broadcast_to(start[others], (len(particles), len(others))))
    assert np.array_equal(LIMITS.clip(particles), particles)


def test_the_filter_spends_the_budget_with_it_and_keeps_m():
    start = gait_pose(20, 30, -10, 5)[None]
    # the left upper arm about right, its forearm straight down where the person's is bent and
    # turned in (a two-camera walk's left arm, docs/fipf.md): a local optimum
    held = (11.0, 19.0, -14.0, 5.0)
    start[0, list(reach.ARMS[0])] = np.deg2rad(held)
    calls = []
    measure = _peaked(0, (14.0, 17.0, 29.0, 52.0), calls, trap_deg=held)
    f = registry.make("fipf", {"reach": True}, LIMITS, FPS, 6561, body=BODY)
    assert f.params["reach"] and f.params["reach_cost"] == reach.cost() == 64 + 50 + 5 * 18
    # the same M as without it: 7 x 828 + the polish's 378 + 204 leaves a filler of 183
    assert (f.params["top_m"], f.params["filler"], f.evaluations_per_frame) == (7, 183, 6561)
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
    assert info.best_weight < 0.91
    assert not off.params["reach"] and off.params["reach_cost"] == 0 and off.params["filler"] == 387


def test_the_camera_rule_gives_way_to_a_small_budget_but_an_asked_search_does_not():
    # by the number of cameras (the tracker gives it): on from reach.MIN_VIEWS
    assert not registry.resolve("fipf", {}, FPS, 6561, views=reach.MIN_VIEWS - 1).reach
    assert registry.resolve("fipf", {}, FPS, 6561, views=reach.MIN_VIEWS).reach
    # a budget too small for it drops it with the polish, unless asked for: then one clear error
    small = registry.resolve("fipf", {"points_per_dof": 2}, FPS, 300, views=4)
    assert not small.reach and small.polish == 0 and small.evaluations() == 300
    with pytest.raises(IPFError, match=f"reach search {reach.cost()}"):
        registry.resolve("fipf", {"points_per_dof": 2, "reach": True}, FPS, 300, views=4)
