"""Shape calibration: proportions and bounds, a body per particle, CMA-ES, the joint fit on a
self-rendered walk, shape files and their errors."""
import json

import numpy as np
import pytest

from ipf_jax.body import BodyShape, default_shape, load_shape
from ipf_jax.body import proportions as P
from ipf_jax.body.model import SHAPE_INDEX
from ipf_jax.cli import main
from ipf_jax.errors import IPFError
from ipf_jax.geometry.posing import gait_pose, lowest_height, place_on_floor
from ipf_jax.geometry.world import up_rotation
from ipf_jax.likelihood import scorer as likelihood
from ipf_jax.likelihood.scorer import Scorer, make_observation
from ipf_jax.tracking.shape_fit import (
    CMAES,
    FramePoses,
    ShapeFitSettings,
    fit_shape,
    lowest_heights,
    shape_doc,
    shape_measure,
    spread_frames,
)
from ipf_jax.viz import synthetic as syn

U = up_rotation("+z")


# -- proportions ---------------------------------------------------------------------------------
def test_template_is_inside_its_bounds_and_the_hip_rule_gives_its_hips():
    t = default_shape()
    P.check_bounds(t.values)
    assert np.allclose(P.hip_rule(t.values), t.values)
    assert np.allclose(P.group_factors(t.values), 1.0)
    assert abs(P.stature(t.values) - 1.75) < 0.01  # the chain floor..head top of the template


def test_build_holds_the_height_and_clips_into_the_bounds():
    t = default_shape()
    theta = np.random.default_rng(0).normal(0, 0.4, (20, P.NUM_GROUPS))
    v = P.build(t.values, theta, height_m=1.83)
    assert np.allclose(P.stature(v), 1.83, atol=1e-6)
    f = P.group_factors(v)
    lo = np.array([1 - P.BOUNDS[g.kind][0] for g in P.GROUPS])
    hi = np.array([1 + P.BOUNDS[g.kind][1] for g in P.GROUPS])
    assert np.all(f >= lo - 0.01) and np.all(f <= hi + 0.01)
    for row in v:
        P.check_bounds(row)
    # no height: a longer thigh makes a taller body, the other groups keep their ratio
    one = np.zeros(P.NUM_GROUPS)
    one[P.GROUP_NAMES.index("thigh")] = np.log(1.1)
    w = P.build(t.values, one)
    assert w[SHAPE_INDEX["thigh"]] == pytest.approx(1.1 * t.values[SHAPE_INDEX["thigh"]])
    assert P.stature(w) == pytest.approx(P.stature(t.values) + 0.1 * t.values[SHAPE_INDEX["thigh"]])


def test_a_reference_lengthened_in_one_parameter_still_builds_a_loadable_shape():
    """The initialisation's proportion search lengthens the trunk parameter alone; the fit's
    group factors read the trunk group's first parameter, so a fitted shape.json had its trunk
    at 1.18 of the template's ratio and --shape refused it. Every built body is inside the
    loader's bounds, parameter by parameter."""
    t = default_shape()
    ref = t.with_factors(trunk=1.12, legs=0.9).values
    theta = np.zeros((3, P.NUM_GROUPS))
    theta[:, P.GROUP_NAMES.index("trunk")] = np.log([1.0, 1.1, 1.15])
    theta[:, P.GROUP_NAMES.index("thigh")] = np.log([1.0, 0.85, 0.85])
    for height in (None, 1.8):
        for row in P.build(ref, theta, height_m=height):
            P.check_bounds(row, tolerance=1e-6)
    far = t.with_factors(trunk=1.3).values
    with pytest.raises(IPFError, match="trunk"):
        P.check_bounds(far)
    P.check_bounds(P.within_bounds(far), tolerance=1e-6)
    assert np.array_equal(P.within_bounds(t.values), t.values)  # inside: unchanged


def test_a_wider_pelvis_moves_the_hips_apart_by_harrington():
    t = default_shape()
    theta = np.zeros(P.NUM_GROUPS)
    theta[P.GROUP_NAMES.index("pelvis")] = np.log(1.1)
    v = P.build(t.values, theta)
    dB = 0.1 * P.pelvis_breadth(t.values)
    d_hw = v[SHAPE_INDEX["hip_half_width"]] - t.values[SHAPE_INDEX["hip_half_width"]]
    assert d_hw == pytest.approx(2 * P.HARRINGTON_SLOPE * dB, rel=1e-6)  # 0.66 of the breadth change


def _moved_by(group: str, factor: float):
    """(parameters a group's factor moves, the new values): the hip joints, which the Harrington
    rule places from the pelvis breadth and the stature, left out."""
    t = default_shape()
    hips = {SHAPE_INDEX["hip_half_width"], SHAPE_INDEX["pelvis_r"]}
    theta = np.zeros(P.NUM_GROUPS)
    theta[P.GROUP_NAMES.index(group)] = np.log(factor)
    v = P.build(t.values, theta)
    return sorted(set(np.flatnonzero(~np.isclose(v, t.values, rtol=1e-9, atol=0))) - hips), v


def _index(*names):
    return sorted(SHAPE_INDEX[n] for n in names)


def test_the_heads_girth_is_apart_from_its_lengths():
    # a narrower head (and neck) changes only their radii; a longer head only its lengths
    t = default_shape()
    for group, changed in (("head_girth", _index("head_r", "neck_r")),
                           ("head", _index("neck", "head_forward", "head_low", "head_high"))):
        moved, v = _moved_by(group, 0.9)
        assert moved == changed, group
        assert np.allclose(v[changed], 0.9 * t.values[changed])
    assert P.GROUPS[P.GROUP_NAMES.index("head_girth")].kind == "girth"


def test_the_foots_girth_is_apart_from_the_ankle_height():
    # a shoe's size moves only the foot's radii; the sole-to-ankle height only the foot's
    # vertical offsets; shapes written when the radii moved with the ankle (up to 1.8x) still load
    radii = _index("foot_r0", "foot_r1")
    offsets = _index("heel_down", "toe_down", "foot_down", "foot_tip_down")
    assert _moved_by("foot_girth", 1.2)[0] == radii
    assert _moved_by("ankle", 1.2)[0] == offsets
    old = default_shape().values.copy()
    old[radii + offsets] *= 1.8  # the old ankle group's largest factor
    P.check_bounds(old)


def test_out_of_bounds_values_are_refused():
    v = default_shape().values.copy()
    v[SHAPE_INDEX["thigh"]] *= 1.4
    with pytest.raises(IPFError, match="thigh .* outside its anthropometric bounds"):
        P.check_bounds(v, "s.json")


# -- a body per particle ------------------------------------------------------------------------
@pytest.fixture(scope="module")
def small_scene():
    cams = syn.ring_cameras(2, width=96, height=72, focal_px=90)
    true = default_shape(1.75).with_factors(legs=1.08)
    q = syn.procedural_walk(3, shape=true)
    masks = syn.render_masks(q, true, cams)
    return cams, true, q, masks


def test_a_body_per_particle_scores_like_one_body_per_call_and_never_recompiles(small_scene):
    cams, _, q, masks = small_scene
    obs = make_observation(list(masks[0]))
    scorer = Scorer(cams, default_shape(), U, chunk=16)
    bodies = [default_shape(h) for h in (1.65, 1.75, 1.85)]
    qq = np.repeat(q[:1], 3, 0)
    per_particle = scorer.counts(qq, obs, shapes=np.stack([b.values for b in bodies]))
    for k, b in enumerate(bodies):
        scorer.set_shape(b)
        assert np.array_equal(scorer.counts(qq[k:k + 1], obs)[0], per_particle[k])
    size = likelihood._geometry_calls_jit._cache_size()
    rng = np.random.default_rng(1)
    for _ in range(3):  # new shape candidates are data: no new trace of the geometry stage
        vals = P.build(default_shape().values, rng.normal(0, 0.1, (3, P.NUM_GROUPS)))
        scorer.counts(qq, obs, shapes=vals)
    assert likelihood._geometry_calls_jit._cache_size() == size


def test_lowest_heights_match_the_reference_placement():
    s = default_shape()
    qs = np.stack([gait_pose(20, 50, -5, 5), gait_pose(5, 5, 5, 5)])
    vals = np.stack([s.values, s.with_factors(legs=1.1).values])
    got = lowest_heights(qs, vals, U)
    assert np.allclose(got, [lowest_height(q, v, U) for q, v in zip(qs, vals)], atol=1e-9)


def test_cmaes_minimises_a_shifted_sphere():
    es = CMAES(np.zeros(6), 0.3, 12, np.random.default_rng(0))
    for _ in range(80):
        x = es.ask()
        es.tell(x, ((x - 0.5) ** 2).sum(1))
    assert np.allclose(es.mean, 0.5, atol=1e-2)


def test_spread_frames():
    assert spread_frames(list(range(10, 42)), 6) == [10, 16, 22, 29, 35, 41]
    assert spread_frames([3], 6) == [3]
    assert spread_frames(list(range(4)), 6) == [0, 1, 2, 3]


# -- the joint fit ------------------------------------------------------------------------------
@pytest.mark.slow
def test_fit_recovers_long_legs_on_a_self_rendered_walk():
    """Self-rendered check: a shod body with legs 8 % longer than the template, fitted from the
    template's poses on 4 frames, comes back with the leg lengths within 4.5 %."""
    cams = syn.ring_cameras(3, width=160, height=120, focal_px=150)
    theta = np.zeros(P.NUM_GROUPS)
    theta[[P.GROUP_NAMES.index("thigh"), P.GROUP_NAMES.index("shank")]] = np.log(1.08)
    theta[P.GROUP_NAMES.index("ankle")] = np.log(P.PRIOR_FACTORS["ankle"])
    values = P.build(default_shape(1.75).values, theta)
    true = BodyShape(values, float(P.stature(values)))
    q_true = syn.procedural_walk(12, shape=true)
    masks = syn.render_masks(q_true, true, cams)
    template = default_shape(1.75)
    scorer = Scorer(cams, template, U, chunk=128)
    frames = []
    for f in (0, 4, 8, 11):
        fn = shape_measure(scorer, make_observation(list(masks[f])))
        q0 = place_on_floor(q_true[f], template.values, U)[None]  # the pose, the wrong legs
        w0 = fn(q0, template.values[None].astype(np.float32))
        frames.append(FramePoses(f, fn, q0, w0))
    from ipf_jax.body.limits import load_limits

    res = fit_shape(frames, template, U, load_limits("default"), height_m=None,
                    settings=ShapeFitSettings(rounds=4, generations=10, population=12, pose_keep=2,
                                              pose_sweeps=2))
    for name in ("thigh", "shank"):
        found, want = res.shape[name], true[name]
        # the template is 7.4 % short; 4.5 % is 2 cm, under a pixel of these 160 x 120 views
        assert abs(found - want) / want < 0.045, (name, found, want)
    assert res.doc["score_history"][-1] > res.doc["score_history"][0]
    assert res.evaluations > 0 and res.doc["evaluations"] == res.evaluations


def test_wider_shoulders_are_scored_with_the_arms_moved_with_them():
    """Self-rendered: a body with shoulders 15 % wider than the template, seen in poses fitted
    with the template. Carried over with the elbows and wrists held where the narrow body had
    them, the true body scores below its own poses; with the angles kept as well
    (``carry_angles``, the default) the fit scores it with exactly those poses."""
    from ipf_jax.body.limits import load_limits
    from ipf_jax.tracking.shape_fit import _Objective

    cams = syn.ring_cameras(3, width=160, height=120, focal_px=150)
    template = default_shape(1.75)
    theta = np.zeros(P.NUM_GROUPS)
    theta[P.GROUP_NAMES.index("shoulders")] = np.log(1.15)
    wide = P.build(template.values, theta)
    true = BodyShape(wide, float(P.stature(wide)))
    q_true = syn.procedural_walk(6, shape=true)
    masks = syn.render_masks(q_true, true, cams)
    scorer = Scorer(cams, template, U, chunk=64)
    limits = load_limits("default")
    frames, direct = [], []
    for f in (1, 4):
        fn = shape_measure(scorer, make_observation(list(masks[f])))
        q0 = place_on_floor(q_true[f], template.values, U)[None]  # the true angles, narrow body
        frames.append(FramePoses(f, fn, q0, fn(q0, template.values[None].astype(np.float32))))
        direct.append(fn(limits.clip(q_true[f][None]), wide[None].astype(np.float32))[0])
    poses = [fr.particles for fr in frames]
    scores = {}
    for carry in (False, True):
        obj = _Objective(frames, template, U, limits, None, ShapeFitSettings(carry_angles=carry))
        got, placed = obj.score(wide[None], poses, template.values)
        scores[carry] = float(got[0])
        assert obj.evaluations == (2 if carry else 1) * len(frames)
    assert scores[True] > scores[False] + 0.05 * abs(scores[True]), scores
    assert scores[True] == pytest.approx(np.mean(direct), rel=0.02), (scores, direct)
    # the returned poses are the ones scored: the better carry-over of each
    for fr, p in zip(frames, placed):
        assert np.allclose(p[0], place_on_floor(fr.particles[0], wide, U), atol=1e-6)


def test_two_searches_give_the_mean_of_their_bodies():
    """``searches = 2``: the body is the mean (log factors) of two searches from the same start,
    the second drawing from ``default_rng((seed, 1))``; one search is what the default runs."""
    from ipf_jax.body.limits import load_limits
    from ipf_jax.tracking.shape_fit import _Objective, _search

    template = default_shape(1.75)
    target = np.log(P.group_factors(template.with_factors(legs=1.06, arms=0.95).values))

    def measure(q, shapes):  # a score that prefers one body, and the pose near standing
        lf = np.log(P.group_factors(np.asarray(shapes, np.float64)))
        return 1.0 - ((lf - target) ** 2).sum(1) - 1e-3 * (np.asarray(q)[:, 3:] ** 2).sum(1)

    limits = load_limits("default")
    q0 = place_on_floor(gait_pose(10, 20, -5, 5), template.values, U)[None]
    frames = [FramePoses(f, measure, q0, measure(q0, template.values[None])) for f in (0, 1)]
    settings = ShapeFitSettings(rounds=1, generations=3, population=6, pose_keep=1, pose_sweeps=1)
    obj = _Objective(frames, template, U, limits, None, settings)
    theta, values, current = obj.starting_point()
    obj.start = float(obj.score(values[None], [fr.particles for fr in current], values)[0][0])
    a, b = (_search(obj, theta, values, current, rng)
            for rng in (np.random.default_rng(3), np.random.default_rng((3, 1))))
    assert not np.allclose(a[0], b[0])  # two different searches
    one = fit_shape(frames, template, U, limits, settings=settings, seed=3)
    two = fit_shape(frames, template, U, limits, settings=settings._replace(searches=2), seed=3)
    assert np.allclose(one.shape.values, a[1])
    assert np.allclose(two.shape.values, obj.body((a[0] + b[0]) / 2))
    assert two.evaluations > one.evaluations
    # every fitted frame's best pose and its weight with the fitted body, as recorded
    rec = one.doc["frame_poses"]
    assert [r["frame"] for r in rec] == [0, 1]
    for r, fr in zip(rec, one.frames):
        assert np.allclose(r["pose"], fr.particles[0], atol=1e-6)
        assert r["weight"] == pytest.approx(measure(fr.particles[:1], one.shape.values[None])[0], abs=1e-6)
    json.dumps(one.doc, allow_nan=False)


def test_the_pose_search_weighs_its_start_with_the_current_body():
    """The kept poses carry the weights of the body they were found with; the compass search
    compares its steps with its start's weight, so it weighs the start again with the body it
    searches for. With a stale weight above every step's, no step would be taken."""
    from ipf_jax.body.limits import load_limits
    from ipf_jax.tracking.shape_fit import _Objective

    template = default_shape(1.75)
    want = place_on_floor(gait_pose(20, 10, -5, 5), template.values, U)

    def measure(q, shapes):  # prefers the pose `want`, whatever the body
        return 1.0 - ((np.asarray(q)[:, 3:] - want[3:]) ** 2).sum(1)

    q0 = place_on_floor(gait_pose(10, 20, -5, 5), template.values, U)[None]
    stale = np.array([5.0])  # a weight no pose reaches: found with another body
    frames = [FramePoses(0, measure, q0, stale)]
    settings = ShapeFitSettings(pose_keep=1, pose_sweeps=2)
    obj = _Objective(frames, template, U, load_limits("default"), None, settings)
    out = obj.refine_poses(template.values, frames)[0]
    assert out.weights[0] == pytest.approx(measure(out.particles[:1], None)[0])
    assert out.weights[0] > measure(q0, None)[0]  # it moved towards `want`
    assert obj.evaluations > 1


def test_angles_are_carried_over_with_three_cameras_or_more():
    from ipf_jax.tracking.shape_fit import CARRY_ANGLES_MIN_VIEWS, for_views

    assert CARRY_ANGLES_MIN_VIEWS == 3
    assert not for_views(ShapeFitSettings(), 1).carry_angles
    assert not for_views(ShapeFitSettings(), 2).carry_angles
    assert for_views(ShapeFitSettings(), 3).carry_angles
    assert for_views(ShapeFitSettings(), 4).carry_angles
    assert not for_views(ShapeFitSettings(carry_angles=False), 4).carry_angles
    two = for_views(ShapeFitSettings(), 2)
    assert two._replace(carry_angles=True, split_prior=1e-1) == ShapeFitSettings()


def test_the_limb_split_prior_is_firmer_with_three_cameras_or_more():
    """10 % of the starting score at the bound with 3+ cameras (measured there), 1 % below; the
    penalty of a split moved by the same amount follows the weight."""
    from ipf_jax.tracking.shape_fit import FEW_VIEWS_SPLIT_PRIOR, _Objective, for_views

    assert ShapeFitSettings().split_prior == 1e-1 and FEW_VIEWS_SPLIT_PRIOR == 1e-2
    assert [for_views(ShapeFitSettings(), c).split_prior for c in (1, 2, 3, 4)] == [1e-2, 1e-2, 1e-1, 1e-1]
    t = default_shape()
    thigh = P.GROUP_NAMES.index("thigh")
    theta = np.zeros(P.NUM_GROUPS)
    theta[thigh] = np.log(1.08)  # a longer thigh, the shank as it was: the split moved
    pen = {}
    for cams in (1, 4):
        obj = _Objective([], t, U, None, None, for_views(ShapeFitSettings(), cams))
        base = obj.penalty(obj.body(np.zeros(P.NUM_GROUPS))[None])[0]
        pen[cams] = obj.penalty(obj.body(theta)[None])[0] - base
    assert pen[1] > 0 and pen[4] > 5 * pen[1]


def test_the_foot_shortens_to_its_own_bound_with_two_cameras_or_more():
    """The foot's length group reaches -30 % (its spheres' radii grow with the shoe's girth); with
    one camera the fit holds it to the lengths' +-15 %, and its prior's scale with it."""
    from ipf_jax.tracking.shape_fit import FOOT_MIN_VIEWS, _Objective, for_views

    assert FOOT_MIN_VIEWS == 2 and P.BOUNDS["foot"] == (0.30, 0.15)
    assert for_views(ShapeFitSettings(), 1).foot_bounds == P.BOUNDS["length"]
    assert for_views(ShapeFitSettings(), 2).foot_bounds is None
    foot = P.GROUP_NAMES.index("foot")
    theta = np.zeros(P.NUM_GROUPS)
    theta[foot] = np.log(0.6)
    t = default_shape()
    assert P.group_factors(P.build(t.values, theta))[foot] == pytest.approx(0.70, abs=1e-3)
    held = P.build(t.values, theta, bounds={"foot": P.BOUNDS["length"]})
    assert P.group_factors(held)[foot] == pytest.approx(0.85, abs=1e-3)
    P.check_bounds(P.build(t.values, theta))  # a shape file may hold the wider foot
    for cams, factor in ((1, 0.85), (4, 0.70)):
        obj = _Objective([], t, U, None, None, for_views(ShapeFitSettings(), cams))
        assert P.group_factors(obj.body(theta))[foot] == pytest.approx(factor, abs=1e-3)
    one, four = (_Objective([], t, U, None, None, for_views(ShapeFitSettings(), c)) for c in (1, 4))
    assert one.half[foot] < four.half[foot]
    assert np.delete(one.half, foot) == pytest.approx(np.delete(four.half, foot))


# -- shape files ----------------------------------------------------------------------------------
def _shape_file(tmp_path, edit=None, name="shape.json"):
    doc = shape_doc(default_shape(1.80), "test")
    if edit:
        edit(doc)
    path = tmp_path / name
    path.write_text(json.dumps(doc))
    return path


def test_shape_doc_round_trips(tmp_path):
    path = _shape_file(tmp_path)
    s = load_shape(path)
    assert s.height_m == pytest.approx(1.80) and np.allclose(s.values, default_shape(1.80).values, atol=1e-6)


@pytest.mark.parametrize("edit, message", [
    (lambda d: d["params"].pop("shank"), "misses parameters: shank"),
    (lambda d: d["params"].update(elbow_wings=0.1), "unknown shape parameters: 'elbow_wings'"),
    (lambda d: d["params"].update(thigh=-0.4), "segment lengths must be positive"),
    (lambda d: d["params"].update(upper_arm=0.55), "upper_arm = 0.5500 m is outside its anthropometric bounds"),
])
def test_bad_shape_files_are_one_error_line_exit_2(tmp_path, capsys, edit, message):
    path = _shape_file(tmp_path, edit)
    assert main(["track", str(tmp_path / "no-such-data"), "--out", str(tmp_path / "o"), "--shape", str(path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0] and str(path) in err[0]


def test_shape_with_a_disagreeing_height_is_an_error(tmp_path, capsys):
    path = _shape_file(tmp_path)
    assert main(["track", str(tmp_path / "d"), "--out", str(tmp_path / "o"), "--shape", str(path),
                 "--height", "1.83"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "disagrees with the shape file's height_m 1.800" in err[0]


def test_shape_with_passes_2_is_an_error(tmp_path, capsys):
    path = _shape_file(tmp_path)
    code = main(["track", str(tmp_path / "d"), "--out", str(tmp_path / "o"), "--shape", str(path),
                 "--height", "1.805", "--passes", "2"])
    assert code == 2
    assert len(capsys.readouterr().err.strip().splitlines()) == 1


# -- runs: shape.json, --shape, --passes 2 --------------------------------------------------------
def _fast_settings():
    from ipf_jax.tracking.initialise import InitSettings
    from ipf_jax.tracking.tracker import TrackSettings

    init = InitSettings(headings=8, position_steps=0, heights_m=(1.75,), modes=1, keep=8,
                        refine_rounds=1, refine_particles=64, pattern_keep=2, pattern_sweeps=1)
    fit = ShapeFitSettings(frames=3, rounds=1, generations=3, population=8, pose_keep=2, pose_sweeps=1,
                           refit_frames=3)
    return TrackSettings(filter="ipf", filter_options={"top_m": 4}, resolution=96, init=init, chunk=64, shape_fit=fit)


@pytest.mark.slow
def test_two_passes_write_both_fits_and_a_reusable_shape(small_scene, tmp_path):
    from ipf_jax.data.dataset import MemoryDataset
    from ipf_jax.tracking import passes as two_pass

    cams, _, _, masks = small_scene
    ds = MemoryDataset(cams, masks, fps=20.0)
    res = two_pass.track(ds, tmp_path / "two", _fast_settings()._replace(passes=2), progress=False)
    run = json.loads((tmp_path / "two" / "run.json").read_text())
    assert [p["pass"] for p in run["passes"]] == [1, 2]
    assert run["shape_fit"]["pass1"]["evaluations"] > 0 and run["shape_fit"]["pass2"]["evaluations"] > 0
    assert run["shape_fit_evaluations"] == run["shape_fit"]["evaluations"]
    assert run["passes"][1]["init_evaluations"] == 1  # pass 2 starts from the refit pose
    assert (tmp_path / "two" / "pass1" / "run.json").is_file()
    shape = load_shape(tmp_path / "two" / "shape.json")
    assert shape["thigh"] == pytest.approx(res.run["shape"]["params"]["thigh"], abs=1e-6)
    # the shape file fixes the body of another run: no shape search, same body
    one = two_pass.track(ds, tmp_path / "fixed", _fast_settings()._replace(
        shape_file=str(tmp_path / "two" / "shape.json")), progress=False)
    assert one.run["shape_fit"] is None and one.run["shape_source"].startswith("shape file")
    assert np.allclose([one.run["shape"]["params"][k] for k in ("thigh", "shank")],
                       [shape["thigh"], shape["shank"]])


def test_one_pass_records_the_fit_apart_from_the_initialisation(small_scene, tmp_path):
    from ipf_jax.data.dataset import MemoryDataset
    from ipf_jax.tracking.tracker import track

    cams, _, _, masks = small_scene
    res = track(MemoryDataset(cams, masks, fps=20.0), tmp_path, _fast_settings(), progress=False)
    fit = res.run["shape_fit"]
    assert fit["frames"] == [0, 1, 2] and fit["evaluations"] == res.run["shape_fit_evaluations"] > 0
    assert fit["evaluations"] >= fit["frame_init_evaluations"] > 0 and fit["seconds"] > 0
    # the one-off stages apart from the tracked frames: the start frame = initialisation + fit
    sec = res.run["seconds"]
    start = res.run["per_frame"][0]
    assert start["status"] == "init" and sec["start"] == pytest.approx(start["seconds"], abs=1e-3)
    assert sec["shape_fit"] == pytest.approx(fit["seconds"], abs=1e-3) and sec["recovery"] == 0
    assert sec["initialisation"] == pytest.approx(sec["start"] - sec["shape_fit"], abs=2e-3)
    assert sec["initialisation"] > 0
    doc = json.loads((tmp_path / "shape.json").read_text())
    assert doc["fit"]["evaluations"] == fit["evaluations"] and doc["source"].startswith("fitted")
    load_shape(tmp_path / "shape.json")  # a valid shape file
