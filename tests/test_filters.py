"""The filters (IPF, APF, SIR): resampling statistics, APF annealing, budgets, pose recovery.

Pose-recovery and tracking tests are SYNTHETIC: the frames are rendered with the tracker's own
capsule model (3 virtual cameras, 160 x 120), so they check the filters' machinery, not accuracy on
real people. All scoring shares one small scene and one chunk size (one set of compiles).
"""
from __future__ import annotations

import functools
import json

import jax
import numpy as np
import pytest

from ipf_jax.body.limits import load_limits
from ipf_jax.body.model import DOF_INDEX, LIMB_JOINTS, NUM_DOF, POINT_NAMES
from ipf_jax.body.shape import default_shape
from ipf_jax.data.dataset import MemoryDataset
from ipf_jax.errors import IPFError
from ipf_jax.filters import apf, registry
from ipf_jax.filters.base import default_noise_rates
from ipf_jax.filters.selection import systematic, top_distinct
from ipf_jax.geometry.world import up_rotation
from ipf_jax.likelihood.scorer import Scorer, make_observation, weights_from_counts
from ipf_jax.tracking.tracker import Tracker, TrackSettings
from ipf_jax.viz import synthetic as syn

FPS = 20.0
HEIGHT = 1.72
CHUNK = 256
LIMITS = load_limits("default")
LIMB = [POINT_NAMES.index(j) for j in LIMB_JOINTS]


# -- systematic resampling ------------------------------------------------------------------
@pytest.mark.parametrize("seed", range(6))
def test_systematic_counts_are_floor_or_ceil_of_n_w(seed):
    rng = np.random.default_rng(seed)
    w = rng.gamma(0.4, size=37)  # (N,) very uneven weights
    num = 100 + 17 * seed
    idx = systematic(jax.random.PRNGKey(seed), w, num)
    counts = np.bincount(idx, minlength=len(w))
    expected = num * w / w.sum()
    assert idx.shape == (num,) and counts.sum() == num
    assert np.all(counts >= np.floor(expected - 1e-9))
    assert np.all(counts <= np.ceil(expected + 1e-9))


def test_systematic_is_unbiased_over_keys():
    w = np.array([0.05, 0.3, 0.001, 0.149, 0.2, 0.3])
    num, trials = 7, 600
    total = np.zeros(len(w))
    for k in range(trials):
        total += np.bincount(systematic(jax.random.PRNGKey(k), w, num), minlength=len(w))
    expected = num * w / w.sum()
    # each count is floor or ceil of its expectation: a Bernoulli spread, std <= 0.5 per draw
    assert np.all(np.abs(total / trials - expected) < 5 * 0.5 / np.sqrt(trials))


def test_systematic_skips_dead_particles_and_survives_all_dead():
    w = np.array([0.0, np.nan, 2.0, -1.0, 1.0])
    idx = systematic(jax.random.PRNGKey(0), w, 300)
    assert set(np.unique(idx)) == {2, 4}
    assert abs(np.mean(idx == 2) - 2 / 3) < 0.01
    idx = systematic(jax.random.PRNGKey(0), np.zeros(4), 8)  # nothing alive: uniform
    assert np.array_equal(np.bincount(idx, minlength=4), [2, 2, 2, 2])


def _top_distinct_by_definition(particles, weights, num):
    """Sort everything by (-w, index), keep each state vector's first occurrence, cycle if short."""
    w = np.where(np.isnan(weights), -np.inf, weights)
    order = np.lexsort((np.arange(len(w)), -w))
    _, first = np.unique(particles[order], axis=0, return_index=True)
    distinct = order[np.sort(first)]
    return distinct[:num] if len(distinct) >= num else np.resize(distinct, num)


@pytest.mark.parametrize("seed", range(4))
def test_top_distinct_matches_deduplicating_the_whole_sorted_set(seed):
    rng = np.random.default_rng(seed)
    for _ in range(300):
        n, d = int(rng.integers(1, 200)), int(rng.integers(1, 6))
        x = rng.integers(-2, 3, size=(n, d)).astype(float)  # many duplicate rows
        x[rng.random((n, d)) < 0.2] = -0.0  # equal to 0.0 as a number, not as bytes
        if rng.random() < 0.3:
            x = rng.normal(size=(n, d))
        w = rng.integers(0, 4, size=n).astype(float)  # many ties
        w[rng.random(n) < 0.1] = np.nan
        w[rng.random(n) < 0.1] = -np.inf
        num = int(rng.integers(1, 2 * n + 2))
        np.testing.assert_array_equal(top_distinct(x, w, num), _top_distinct_by_definition(x, w, num))
        shift = rng.choice([0.0, -0.0, 1e-17, 0.3, 1e16], size=d)  # 1e16 rounds rows together
        np.testing.assert_array_equal(top_distinct(x, w, num, shift),
                                      _top_distinct_by_definition(x + shift, w, num))


def test_top_distinct_with_non_finite_rows_among_the_examined_or_not():
    """A NaN or an infinity among the examined rows takes the general comparison; one outside
    them does not change the result."""
    x = np.array([[1.0, 0.0], [1.0, -0.0], [np.nan, 2.0], [3.0, np.inf], [4.0, 4.0], [1.0, 0.0]])
    for w in ([5, 4, 3, 2, 1, 0], [5, 4, 0, 1, 3, 2], [0, 1, 5, 4, 3, 2]):
        w = np.array(w, float)
        for num in (1, 2, 3, 4, 7):
            np.testing.assert_array_equal(top_distinct(x, w, num), _top_distinct_by_definition(x, w, num))


# -- APF annealing ----------------------------------------------------------------------------
@pytest.mark.parametrize("target", [0.1, 0.3, 0.5, 0.8])
@pytest.mark.parametrize("seed", [0, 1])
def test_beta_search_hits_the_target_survival_fraction(target, seed):
    rng = np.random.default_rng(seed)
    likelihood = rng.uniform(0.5, 3.0, 2000)  # the spread of w = Nc/(Ns+Nm) on real frames
    likelihood[:50] = 0.0  # dead particles (model entirely off the masks) count as non-survivors
    w, beta = apf.annealed_weights(likelihood, target)
    assert beta > 0
    assert apf.effective_fraction(w) == pytest.approx(target, abs=1e-9)
    assert np.all(w[:50] == 0) and w.max() == pytest.approx(1.0)


def test_beta_search_edge_cases():
    assert apf.anneal_beta(np.full(10, 2.0), 0.5) == 0.0  # all equal: every beta is the same
    mostly_dead = np.r_[np.ones(3), np.zeros(7)]
    assert apf.anneal_beta(mostly_dead, 0.5) == 0.0  # 30% alive: already below 50% at beta = 0
    assert apf.anneal_beta(np.zeros(5), 0.5) == 0.0
    w, _ = apf.annealed_weights(np.full(4, np.nan), 0.5)
    assert np.array_equal(w, np.ones(4))  # nothing alive: resample uniformly
    betas = [apf.anneal_beta(np.linspace(1, 2, 100), t) for t in (0.2, 0.5, 0.9)]
    assert betas[0] > betas[1] > betas[2] > 0  # fewer survivors wanted -> sharper weights


def test_apf_layers_shrink_the_noise_and_spend_the_budget():
    settings = apf.APFSettings(particles=3000, layers=3, survival=0.5)
    assert np.allclose(apf.layer_scales(settings), [1.0, 0.5 ** 0.5, 0.5])  # covariance x alpha
    assert np.allclose(apf.layer_scales(settings._replace(noise_decay=0.9)), [1.0, 0.9, 0.81])
    f = apf.build(settings, LIMITS, FPS)
    seen = []

    def measure(x):  # flat likelihood: selection keeps everyone, so only the noise acts
        seen.append(x.copy())
        return np.ones(len(x))

    start = np.zeros((1, NUM_DOF))
    start[0, DOF_INDEX["left_knee_flexion"]] = 0.6  # away from its limit, so no clipping
    _, info = f.step(jax.random.PRNGKey(3), f.init(start, np.ones(1)), measure)
    assert [len(x) for x in seen] == [3000] * 3 and info.evaluations == 9000
    knee = DOF_INDEX["left_knee_flexion"]
    std = default_noise_rates()[knee] / FPS
    assert np.std(seen[0][:, knee]) == pytest.approx(std, rel=0.06)  # layer 0: full std
    # after layer m the spread is the sum of the variances added so far: 1 + 1/2 + 1/4
    assert np.std(seen[2][:, knee]) == pytest.approx(std * np.sqrt(1.75), rel=0.1)


# -- budgets ------------------------------------------------------------------------------------
@pytest.mark.parametrize("budget", [81, 100, 405, 6561, 20000])
def test_budget_maps_onto_the_largest_setting_within_it(budget):
    f = registry.make("ipf", {}, LIMITS, FPS, budget)
    assert f.evaluations_per_frame <= budget < f.evaluations_per_frame + 81
    assert f.params["top_m"] == budget // 81
    f = registry.make("apf", {}, LIMITS, FPS, budget)
    assert f.params["layers"] == 5 and f.params["particles"] == budget // 5
    assert f.evaluations_per_frame <= budget < f.evaluations_per_frame + 5
    assert registry.make("sir", {}, LIMITS, FPS, budget).evaluations_per_frame == budget


def test_explicit_parameters_win_over_the_budget():
    def ev(name, opts, budget=20000):
        return registry.make(name, opts, LIMITS, FPS, budget).evaluations_per_frame

    assert ev("ipf", {"top_m": 10}) == 810
    assert ev("ipf", {"particles": 1000}) == 12 * 81
    assert ev("ipf", {"points_per_dof": 2}) == (20000 // 16) * 16
    assert ev("apf", {"layers": 3}) == 3 * 6666
    f = registry.make("apf", {"particles": 3000}, LIMITS, FPS, 20000)
    assert (f.params["particles"], f.params["layers"]) == (3000, 6)  # the budget fills the layers
    assert ev("apf", {"particles": 100, "layers": 2}) == 200
    assert ev("sir", {"particles": 123}) == 123
    assert ev("sir", {"particles": None}) == 20000  # None means "not given"


@pytest.mark.parametrize("name, options, budget, problem", [
    ("pf", {}, None, "unknown filter 'pf'"),
    ("ipf", {}, 0, "budget must be"),
    ("sir", {}, 2.5, "budget must be"),
    ("ipf", {}, 50, "cannot hold one grid of I = 81"),
    ("apf", {}, 3, "cannot feed 5 layers"),
    ("apf", {"particles": 500}, 400, "cannot weigh 500 particles"),
    ("ipf", {"top_m": 100}, 6561, "8100 evaluations per frame, over the budget of 6561"),
    ("apf", {"particles": 4000, "layers": 5}, 19999, "over the budget of 19999"),
    ("sir", {"layers": 3}, None, "layers do not apply to the sir filter"),
    ("ipf", {"particles": 810, "top_m": 10}, None, "either --particles or --top-m"),
    ("apf", {"survival": 1.5}, None, "survival fraction"),
    ("apf", {"layers": 0}, None, "at least one layer"),
    ("sir", {"noise_scale": -1.0}, None, "noise scale"),
    ("sir", {"noise_scale": float("inf")}, None, "noise scale must be >= 0 and finite"),
    ("apf", {"noise_scale": float("inf")}, None, "noise scale must be >= 0 and finite"),
    ("fipf", {"noise_scale": float("inf")}, None, "noise scale must be >= 0 and finite"),
    ("fipf", {"speed_scale": float("inf")}, None, "speed scale must be > 0 and finite"),
    ("ipf", {"noise_scale": float("inf")}, None, "noise scale must be >= 0 and finite"),
    ("ipf", {"max_speed_deg_s": float("inf")}, None, "max angular speed must be > 0 and finite"),
    ("ipf", {"interval_width_deg": float("inf")}, None, "interval width must be > 0 degrees and finite"),
    ("sir", {"particles": 0}, None, "at least one particle"),
    ("sir", {"particles": 10 ** 10}, None, "10000000000 likelihood evaluations per frame, more than 1000000"),
    ("ipf", {"points_per_dof": 50, "top_m": 2}, None, "12500000 likelihood evaluations per frame"),
    ("apf", {"particles": 10, "layers": 10 ** 6}, None, "more than 1000000"),
])
def test_impossible_settings_are_one_clear_error(name, options, budget, problem):
    with pytest.raises(IPFError, match=problem):
        registry.make(name, options, LIMITS, FPS, budget)


def test_options_for_keeps_what_each_filter_understands():
    opts = {"layers": 3, "top_m": 5, "noise_scale": 0.5, "particles": None}
    assert registry.options_for("apf", opts) == {"layers": 3, "noise_scale": 0.5}
    assert registry.options_for("ipf", opts) == {"top_m": 5, "noise_scale": 0.5}
    assert registry.options_for("sir", opts) == {"noise_scale": 0.5}
    with pytest.raises(IPFError, match="unknown filter"):
        registry.options_for("kalman", opts)


# -- the shared synthetic scene -------------------------------------------------------------------
@pytest.fixture(scope="module")
def scene():
    """SYNTHETIC: 3 ring cameras at 160 x 120, a walking pose, its masks and a perturbed start."""
    shape = default_shape(HEIGHT)
    cams = syn.ring_cameras(3, width=160, height=120, focal_px=300.0)
    walk = syn.procedural_walk(8, FPS, shape=shape)  # (T, D)
    truth = walk[5]
    masks = syn.render_masks(truth[None], shape, cams)[0]  # (C, H, W)
    start = truth.copy()
    for dof, sign in (("left_hip_flexion", 1), ("right_hip_flexion", -1),
                      ("left_knee_flexion", -1), ("right_knee_flexion", 1)):
        start[DOF_INDEX[dof]] += sign * np.deg2rad(8.0)
    start[:3] += [0.02, -0.02, 0.01]
    return {"shape": shape, "cams": cams, "walk": walk, "truth": truth, "masks": masks,
            "start": LIMITS.clip(start)}


def limb_error(scene, q: np.ndarray) -> float:
    """Mean 3D distance (m) of the 12 limb joints of pose ``q`` from the true pose's."""
    ours, true = syn.joints_of(np.stack([q, scene["truth"]]), scene["shape"])[:, LIMB]
    return float(np.linalg.norm(ours - true, axis=-1).mean())


@pytest.mark.parametrize("name, budget, steps, noise, estimates", [
    ("ipf", 486, 5, 0.3, ("best",)),  # the paper's estimate: the heaviest particle
    ("fipf", 800, 2, 0.3, ("best",)),  # 800 = M 1 x 774 + 26 filler
    ("apf", 600, 6, 0.3, ("best", "mean")),
    # Condensation's estimate is the mean: its heaviest particle carries a full step of 31-DOF
    # diffusion (nothing narrows it within a frame), so it stays a pixel or two off; its noise is
    # all it has to converge with (half the walking rates here: a static subject)
    ("sir", 600, 25, 0.5, ("mean",)),
])
def test_filter_recovers_a_known_pose_from_a_perturbed_start(scene, name, budget, steps, noise,
                                                            estimates):
    """SYNTHETIC (self-rendered frame): a static subject, legs 8 deg and root 2-3 cm off at start."""
    obs = make_observation(list(scene["masks"]))
    scorer = Scorer(scene["cams"], scene["shape"], up_rotation("+z"), chunk=CHUNK)

    def measure(particles):
        return weights_from_counts(scorer.counts(particles, obs), obs.active)[0]

    f = registry.make(name, {"noise_scale": noise}, LIMITS, FPS, budget)  # static: gentle noise
    start = scene["start"][None]
    state = f.init(start, measure(start))
    before = limb_error(scene, scene["start"])
    for k in range(steps):
        state, info = f.step(jax.random.fold_in(jax.random.PRNGKey(7), k), state, measure)
    assert scorer.evaluations == 1 + steps * f.evaluations_per_frame
    assert before > 0.05
    for which in estimates:
        after = limb_error(scene, getattr(info, which))
        assert after < 0.025, f"{name} {which}: {1000 * before:.0f} -> {1000 * after:.0f} mm"
    assert info.best_weight > 2 * measure(start)[0]


# -- exact budget accounting in a tracking run ------------------------------------------------
@pytest.mark.parametrize("name", registry.NAMES)
def test_run_json_reports_exactly_what_the_scorer_evaluated(scene, tmp_path, name):
    """SYNTHETIC walk, 3 frames from a given initial pose (1 initial evaluation)."""
    masks = syn.render_masks(scene["walk"][:3], scene["shape"], scene["cams"])
    ds = MemoryDataset(scene["cams"], masks, fps=FPS, up_axis="+z")
    opts = {"points_per_dof": 2} if name == "fipf" else {}  # 2 x 84 per kept particle fits 300
    settings = TrackSettings(filter=name, budget=300, init_pose=scene["walk"][0], height_m=HEIGHT,
                             filter_options=opts,
                             chunk=CHUNK, confidence_drop=0.0)
    tracker = Tracker(ds, settings)
    tracker.run(tmp_path, progress=False)
    run = json.loads((tmp_path / "run.json").read_text())
    per_frame = [r["evaluations"] for r in run["per_frame"]]
    expected = {"ipf": 243, "fipf": 300, "apf": 300, "sir": 300}[name]
    assert run["evaluations_per_frame"] == expected <= run["settings"]["budget"]
    assert per_frame == [0, expected, expected]
    assert run["init_evaluations"] == 1
    assert tracker.scorer.evaluations == run["init_evaluations"] + sum(per_frame)
    assert run["chunk"] == CHUNK  # given, so kept


@pytest.mark.parametrize("name", registry.NAMES)
@pytest.mark.parametrize("budget", [300, 6561, 20000])
def test_each_filter_declares_the_calls_it_makes(name, budget):
    opts = {"points_per_dof": 2} if name == "fipf" and budget < 774 else {}
    f = registry.make(name, opts, LIMITS, FPS, budget)
    assert sum(f.calls) == f.evaluations_per_frame and all(n > 0 for n in f.calls)


# -- factored IPF --------------------------------------------------------------------------------
@pytest.mark.parametrize("budget", [774, 1000, 1152, 6561, 20000])
def test_fipf_spends_the_budget_exactly(budget):
    f = registry.make("fipf", {}, LIMITS, FPS, budget)
    polish = 378 if budget >= 774 + 378 else 0  # the default polish: 6 sweeps of 63
    assert f.evaluations_per_frame == budget and f.params["polish_cost"] == polish
    rest = budget - polish
    assert f.params["top_m"] == rest // 774 and f.params["filler"] == rest % 774


def test_fipf_groups_cover_every_dof_once_and_bad_groups_are_refused():
    from ipf_jax.body.model import DOF_NAMES
    from ipf_jax.filters import fipf
    named = [d for _, grid, noise in fipf.GROUPS for d in (*grid, *noise)]
    assert sorted(named) == sorted(DOF_NAMES)
    with pytest.raises(IPFError, match="every DOF exactly once"):
        fipf.validate(fipf.FIPFSettings(groups=fipf.GROUPS[:-1]))
    with pytest.raises(IPFError, match="774 per kept particle"):
        registry.make("fipf", {"points_per_dof": 3}, LIMITS, FPS, 500)
    small = registry.make("fipf", {}, LIMITS, FPS, 500)  # not given: 2 points per DOF (168)
    assert (small.params["points_per_dof"], small.params["top_m"], small.evaluations_per_frame) == (2, 2, 500)


def test_fipf_evaluates_what_it_reports_and_never_loses_the_best():
    """A fake likelihood (closeness to a target pose): the weights the filter sees are counted, and
    the frame's best is at least the kept particles' best (the centre child is the parent)."""
    from ipf_jax.filters import fipf
    target = LIMITS.clip(np.full(NUM_DOF, 0.05))
    calls = []

    def measure(p):
        calls.append(len(p))
        return np.exp(-np.abs(p - target).sum(1))

    f = registry.make("fipf", {}, LIMITS, FPS, 1000)  # 3 points per DOF: the centre is a child
    start = LIMITS.clip(np.zeros(NUM_DOF))[None]
    state = f.init(start, measure(start))
    calls.clear()
    weights = []
    for k in range(3):
        state, info = f.step(jax.random.PRNGKey(k), state, measure)
        assert sum(calls) == info.evaluations == 1000
        assert tuple(calls) == f.calls  # what the tracker sizes the scorer's chunks from
        calls.clear()
        weights.append(info.best_weight)
    assert weights == sorted(weights) and weights[-1] > float(measure(start)[0])
    assert fipf.max_speed("left_knee_flexion") == fipf.MAX_SPEEDS["knee_flexion"]


@pytest.mark.parametrize("budget", [2000, 6561])
def test_fipf_polish_spends_inside_the_budget_and_never_loses_the_best(budget):
    """With ``polish``, the compass sweeps are counted in the budget (M shrinks to make room), the
    calls are the declared ones, and the same frame's best is at least the unpolished best."""
    from ipf_jax.filters.compass import sweep_cost
    target = LIMITS.clip(np.full(NUM_DOF, 0.05))
    calls = []

    def measure(p):
        calls.append(len(p))
        return np.exp(-np.abs(p - target).sum(1))

    cost = 6 * sweep_cost(1)
    f = registry.make("fipf", {"polish": 6}, LIMITS, FPS, budget)
    assert cost == 6 * (2 * NUM_DOF + 1) and f.params["polish_cost"] == cost
    assert f.evaluations_per_frame == budget and f.params["top_m"] == (budget - cost) // 774
    plain = registry.make("fipf", {"top_m": f.params["top_m"], "filler": f.params["filler"], "polish": 0},
                          LIMITS, FPS)
    start = LIMITS.clip(np.zeros(NUM_DOF))[None]
    state = plain_state = f.init(start, measure(start))
    for k in range(2):
        calls.clear()
        state, info = f.step(jax.random.PRNGKey(k), state, measure)
        assert sum(calls) == info.evaluations == budget and tuple(calls) == f.calls
        plain_state, plain_info = plain.step(jax.random.PRNGKey(k), plain_state, measure)
        if k == 0:  # the same start and keys: the polish only adds to the same rounds' particles
            assert info.best_weight > plain_info.best_weight
    assert float(state.weights.max()) == info.best_weight  # the polished best goes on


def test_fipf_polish_is_dropped_by_small_budgets_unless_given():
    small = registry.make("fipf", {}, LIMITS, FPS, 300)
    assert small.params["polish"] == 0
    given = registry.make("fipf", {"polish": 1, "points_per_dof": 2, "rounds": 1}, LIMITS, FPS, 300)
    assert given.params["polish"] == 1 and given.evaluations_per_frame == 300
    with pytest.raises(IPFError, match="its polish takes 378"):
        registry.make("fipf", {"polish": 6, "points_per_dof": 3}, LIMITS, FPS, 1000)


def test_pattern_search_is_the_compass_search_with_the_body_held():
    from ipf_jax.filters.compass import compass_search
    from ipf_jax.tracking.initialise import REFINE_STD, pattern_search
    target = LIMITS.clip(np.full(NUM_DOF, 0.1))
    rng = np.random.default_rng(0)
    p = LIMITS.clip(rng.normal(0, 0.05, (5, NUM_DOF)))

    def measure(q, shape=None):
        return np.exp(-np.abs(q - target).sum(1))

    a = pattern_search(p, measure(p), measure, "body", LIMITS, keep=2, sweeps=3, first_step=0.5)
    b = compass_search(p, measure(p), measure, LIMITS.clip, REFINE_STD * 0.5, keep=2, sweeps=3)
    assert all(np.array_equal(x, y) for x, y in zip(a, b)) and a[2] == 3 * 2 * (2 * NUM_DOF + 1)
    assert a[1].max() > measure(p).max()


# -- compiled draws and the host prediction: the same numbers as the plain eager code ----------
def test_compiled_draws_are_the_eager_draws_bit_for_bit():
    from ipf_jax.filters.base import resample_draws, standard_normal
    from ipf_jax.tracking.tracker import frame_key

    key = jax.random.PRNGKey(11)
    for shape in [(6561, 27), (4000, NUM_DOF), (7,)]:
        eager = np.asarray(jax.random.normal(key, shape, dtype=np.float32))
        assert np.asarray(standard_normal(key, shape)).tobytes() == eager.tobytes()
    k1, k2 = jax.random.split(key)
    u, z = resample_draws(key, (300, NUM_DOF))
    assert float(u) == float(jax.random.uniform(k1, ()))
    assert np.asarray(z).tobytes() == np.asarray(jax.random.normal(k2, (300, NUM_DOF))).tobytes()
    for layer, (u, z) in enumerate(apf.layer_draws(key, 5, (300, NUM_DOF))):
        k1, k2 = jax.random.split(jax.random.fold_in(key, layer))
        assert float(u) == float(jax.random.uniform(k1, ()))
        assert np.asarray(z).tobytes() == np.asarray(jax.random.normal(k2, (300, NUM_DOF))).tobytes()
    for frame in (0, 1, 17, 4096):
        for salt in (0, 1, 2):
            want = jax.random.fold_in(jax.random.fold_in(key, frame), salt)
            assert np.array_equal(frame_key(key, np.uint32(frame), np.uint32(salt)), want)


@pytest.mark.parametrize("name", ["ipf", "fipf", "apf", "sir"])
def test_draws_given_ahead_are_the_draws_of_the_step(name):
    """``step(key, ..., drawn=f.draws(key))`` sees exactly the particles of ``step(key, ...)``;
    draws of the wrong shape (fewer than M distinct particles to start from) are drawn again."""
    f = registry.make(name, {}, LIMITS, FPS, 600)
    rng = np.random.default_rng(5)
    particles = LIMITS.clip(rng.normal(0, 0.3, (80, NUM_DOF)))
    weights = rng.uniform(0, 1, 80)
    key = jax.random.PRNGKey(9)
    seen_by = functools.partial(_seen_by, f, key)
    state = f.init(particles, weights)
    assert seen_by(state, drawn=f.draws(key)) == seen_by(state)
    few = f.init(particles[:1], weights[:1])  # one particle: fewer than M kept
    assert seen_by(few, drawn=f.draws(key)) == seen_by(few)
    other = registry.make(name, {}, LIMITS, FPS, 300)  # another budget: draws of other shapes
    assert seen_by(state, drawn=other.draws(key)) == seen_by(state)


def _seen_by(f, key, state, **kwargs) -> bytes:
    """The bytes of every particle set ``f.step(key, state, ..., **kwargs)`` measures."""
    seen = []
    f.step(key, state, lambda x: seen.append(x) or np.ones(len(x)), **kwargs)
    return b"".join(x.tobytes() for x in seen)


@pytest.mark.parametrize("name", ["ipf", "fipf", "apf", "sir"])
def test_a_shifted_step_is_the_step_of_the_moved_particles(name):
    """``step(..., shift=s)`` sees bit for bit the particles of ``step`` on ``moved(state, s)``
    (IPF and the factored filter shift only the particles they keep), also where the shift
    rounds two particles together."""
    from ipf_jax.filters.base import moved

    f = registry.make(name, {}, LIMITS, FPS, 600)
    rng = np.random.default_rng(3)
    particles = LIMITS.clip(rng.normal(0, 0.3, (80, NUM_DOF)))
    particles[:, :3] = rng.normal(0, 2.0, (80, 3))
    particles[1] = particles[0]
    particles[1, 0] = np.nextafter(particles[0, 0], np.inf)  # one ulp apart: one row once moved
    weights = rng.uniform(0, 1, 80)
    weights[:2] = 2.0, 1.9
    shift = np.r_[1e3 * rng.normal(size=3), np.zeros(NUM_DOF - 3)]
    assert (particles[0] + shift == particles[1] + shift).all()
    key = jax.random.PRNGKey(4)
    seen_by = functools.partial(_seen_by, f, key)
    state = f.init(particles, weights)
    assert seen_by(state, shift=shift) == seen_by(moved(state, shift))
    assert seen_by(state, shift=shift, drawn=f.draws(key)) == seen_by(moved(state, shift))
    assert seen_by(state, shift=None) == seen_by(state)


def _ipf_step_by_definition(settings, limits, key, particles, weights):
    """IPF's prediction written out plainly: each kept particle repeated I times, its L DOFs
    moved over the grid, the rest noised, clipped."""
    from ipf_jax.body.model import DOF_INDEX as IDX
    from ipf_jax.filters.base import gaussian_noise, rate_std
    from ipf_jax.filters.ipf import interval_grid

    grid = interval_grid(settings, FPS)
    L = np.array([IDX[d] for d in settings.interesting])
    R = np.setdiff1d(np.arange(NUM_DOF), L)
    kept = particles[top_distinct(particles, weights, settings.top_m)]
    new = np.repeat(kept, len(grid), axis=0)
    new[:, L] = (kept[:, None, L] + grid[None]).reshape(-1, len(L))
    std = rate_std(default_noise_rates()[R], FPS) * settings.noise_scale
    new[:, R] += gaussian_noise(key, (len(new), len(R)), std)
    return limits.clip(new)


@pytest.mark.parametrize("seed", [0, 1])
def test_ipf_prediction_is_the_plain_definition_bit_for_bit(seed):
    from ipf_jax.filters import ipf

    rng = np.random.default_rng(seed)
    settings = ipf.IPFSettings(top_m=7)
    f = ipf.build(settings, LIMITS, FPS)
    particles = LIMITS.clip(rng.normal(0, 0.3, (50, NUM_DOF)))
    particles[:, DOF_INDEX["root_yaw"]] = 3.1  # children wrap around +-pi
    weights = rng.uniform(0, 1, 50)
    seen = []
    key = jax.random.PRNGKey(seed)
    f.step(key, f.init(particles, weights), lambda x: seen.append(x) or np.ones(len(x)))
    want = _ipf_step_by_definition(settings, LIMITS, key, particles, weights)
    assert seen[0].tobytes() == want.tobytes()


def test_resample_diffuse_is_systematic_then_noise_bit_for_bit():
    from ipf_jax.filters.base import gaussian_noise, rate_std, resample_diffuse

    rng = np.random.default_rng(2)
    particles = rng.normal(0, 0.2, (400, NUM_DOF))
    weights = rng.uniform(0, 1, 400)
    std = rate_std(default_noise_rates(), FPS)
    key = jax.random.PRNGKey(4)
    k1, k2 = jax.random.split(key)
    want = LIMITS.clip(particles[systematic(k1, weights, 300)] + gaussian_noise(k2, (300, NUM_DOF), std))
    got = resample_diffuse(key, particles, weights, std, LIMITS, 300)
    assert got.tobytes() == want.tobytes()


def test_apf_reuses_the_annealing_of_its_last_layer_bit_for_bit(monkeypatch):
    """The weights an APF step starts from are the last layer's of the step before, annealed at
    its end already: the next step reuses them (one annealing fewer a frame) and moves the
    particles exactly as a filter that anneals them again."""
    settings = apf.APFSettings(particles=300, layers=3)
    rng = np.random.default_rng(5)
    state = apf.init_state(LIMITS.clip(rng.normal(0, 0.2, (300, NUM_DOF))), rng.uniform(0, 1, 300))

    def measure(x):  # a smooth likelihood of the pose, some particles dead
        w = np.exp(-np.sum(x[:, 3:] ** 2, axis=1))
        w[::17] = 0.0
        return w

    calls = []
    real = apf.annealed_weights
    monkeypatch.setattr(apf, "annealed_weights", lambda lk, t: calls.append(1) or real(lk, t))
    warm = apf.build(settings, LIMITS, FPS)
    keys = jax.random.split(jax.random.PRNGKey(9), 2)
    first, _ = warm.step(keys[0], state, measure)
    calls.clear()
    second, _ = warm.step(keys[1], first, measure)
    assert len(calls) == settings.layers  # the start's annealing came from the step before
    calls.clear()
    cold, _ = apf.build(settings, LIMITS, FPS).step(keys[1], first, measure)
    assert len(calls) == settings.layers + 1
    assert second.particles.tobytes() == cold.particles.tobytes()
    assert second.weights.tobytes() == cold.weights.tobytes()
    # other weights (a checkpoint of another run, a moved state) are annealed, not taken
    other = first._replace(weights=first.weights[::-1].copy())
    calls.clear()
    a, _ = warm.step(keys[1], other, measure)
    b, _ = apf.build(settings, LIMITS, FPS).step(keys[1], other, measure)
    assert len(calls) == 2 * settings.layers + 2 and a.particles.tobytes() == b.particles.tobytes()


@pytest.mark.parametrize("seed", [0, 1])
def test_effective_fraction_is_the_plain_formula_bit_for_bit(seed):
    rng = np.random.default_rng(seed)
    for n in (1, 2, 7, 300, 4000, 4097, 20000):
        w = rng.uniform(0, 1, n) ** rng.uniform(0.1, 50)
        w[rng.random(n) < 0.1] = 0.0
        w[0] = 0.5  # not all dead
        plain = float(np.sum(w)) ** 2 / (n * float(np.sum(w * w)))
        assert apf.effective_fraction(w) == plain
        assert apf.effective_fraction(w, np.empty(n)) == plain


def _anneal_beta_by_definition(likelihood, target, iters=64):
    """The annealing beta by plain bisection, every one of its ``iters`` steps taken (the search
    :func:`apf.anneal_beta` made before regula falsi: its reference)."""
    lw = np.log(np.where(likelihood > 0, likelihood, 1.0))
    live = np.isfinite(likelihood) & (likelihood > 0)
    lw = lw[live] - lw[live].max()

    def fraction(beta):
        return live.mean() * apf.effective_fraction(np.exp(beta * lw))

    if fraction(0.0) <= target or lw.min() == 0.0:
        return 0.0
    hi = 1.0
    while fraction(hi) > target:
        if hi >= apf._MAX_BETA:
            return hi
        hi *= 2.0
    lo = hi / 2.0 if hi > 1.0 else 0.0
    for _ in range(iters):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if fraction(mid) > target else (lo, mid)
    return 0.5 * (lo + hi)


def _likelihoods(rng, n, kind):
    """Likelihoods of several shapes, some dead: powers of uniforms, a narrow band, exponentials,
    and ties at the maximum."""
    if kind == 0:
        lk = rng.uniform(0, 1, n) ** rng.uniform(0.1, 300)
    elif kind == 1:
        lk = rng.uniform(0.4, 0.9, n)
    elif kind == 2:
        lk = np.exp(-rng.exponential(rng.uniform(0.001, 50), n))
    else:
        lk = rng.uniform(0.5, 0.6, n)
        lk[rng.random(n) < 0.3] = 0.6
    lk[rng.random(n) < rng.uniform(0, 0.5)] = 0.0
    return lk


def _fraction_at(likelihood, beta):
    lw = np.log(np.where(likelihood > 0, likelihood, 1.0))
    live = np.isfinite(likelihood) & (likelihood > 0)
    return live.mean() * apf.effective_fraction(np.exp(beta * (lw[live] - lw[live].max())))


def _agrees_with_the_bisection(likelihood, target):
    """:func:`apf.anneal_beta` against the 64-step bisection: the same 0 or very large beta in the
    edge cases; otherwise the effective fraction within ``FRACTION_TOL`` of the target (rounding
    of the recomputation allowed) and beta within 1e-7 of the bisection's."""
    want = _anneal_beta_by_definition(likelihood, target) if (likelihood > 0).any() else 0.0
    got = apf.anneal_beta(likelihood, target)
    if want == 0.0 or want >= apf._MAX_BETA:
        assert got == want
        return
    assert abs(np.log(_fraction_at(likelihood, got) / target)) <= 2 * apf.FRACTION_TOL
    assert abs(got - want) <= 1e-7 * want


@pytest.mark.parametrize("kind", [0, 1, 2, 3])
def test_beta_search_agrees_with_the_full_bisection(kind):
    """Regula falsi to the fraction's tolerance finds the bisection's beta, on likelihoods of
    several shapes, sizes and targets (ties at the maximum, dead particles, a few particles)."""
    for seed in range(12):
        rng = np.random.default_rng(100 * kind + seed)
        lk = _likelihoods(rng, int(rng.choice([3, 100, 4000, 6561])), kind)
        for target in (0.05, 0.5, 0.95):
            _agrees_with_the_bisection(lk, target)


def test_beta_search_evaluates_few_fractions(monkeypatch):
    """Over 50 layers of 4000 silhouette-like likelihoods at most 10 evaluations of the fraction
    on the mean and 12 at most (the bisection to the last bit of beta: 57; with a regula falsi
    bracket to the last bit: 33-36)."""
    calls, real = [], apf.effective_fraction
    monkeypatch.setattr(apf, "effective_fraction", lambda w, s=None: calls.append(1) or real(w, s))
    rng, counts = np.random.default_rng(7), []
    for _ in range(50):
        lk = rng.uniform(0.4, 0.8, 4000) ** rng.uniform(1, 4)
        calls.clear()
        apf.anneal_beta(lk, 0.5)
        counts.append(len(calls))
    assert np.mean(counts) <= 10 and max(counts) <= 12
    for lk in (np.random.default_rng(0).uniform(0.5, 0.8, 4000) ** 3,):
        _agrees_with_the_bisection(lk, 0.5)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_beta_search_agrees_with_the_bisection_on_powered_uniforms(seed):
    rng = np.random.default_rng(seed)
    for n, power in [(4000, 1.0), (500, 20.0), (3, 0.5), (2000, 200.0)]:
        likelihood = rng.uniform(0, 1, n) ** power
        likelihood[rng.random(n) < 0.1] = 0.0
        for target in (0.1, 0.5, 0.9):
            _agrees_with_the_bisection(likelihood, target)
