"""The absolute loss test, the lost status and recovery, on small self-rendered scenes."""
import json

import numpy as np
import pytest

from ipf_jax.analysis.gait.io import read_joints_csv
from ipf_jax.body import default_shape
from ipf_jax.body.limits import load_limits
from ipf_jax.body.model import DOF_INDEX
from ipf_jax.data.dataset import MemoryDataset
from ipf_jax.errors import IPFError
from ipf_jax.geometry.posing import POSTURES_DEG, gait_pose, place_on_floor, posture_pose
from ipf_jax.geometry.world import up_rotation
from ipf_jax.likelihood.scorer import Scorer, make_observation, weights_from_counts
from ipf_jax.tracking import loss
from ipf_jax.tracking.initialise import InitSettings
from ipf_jax.tracking.recovery import recover
from ipf_jax.tracking.tracker import TrackSettings, track
from ipf_jax.viz import synthetic as syn

SHAPE = default_shape(1.75)
U = up_rotation("+z")
FAST_INIT = InitSettings(headings=8, position_steps=0, heights_m=(1.75,), modes=1, keep=8,
                         refine_rounds=1, refine_particles=64, pattern_keep=2, pattern_sweeps=1,
                         posture_modes=0)
SETTINGS = TrackSettings(filter_options={"top_m": 4}, resolution=160, init=FAST_INIT, chunk=128,
                         checkpoint_every=2)


def test_shares_and_levels():
    counts = np.array([[80, 20, 10], [30, 70, 5], [0, 0, 0]])  # (Nc, Ns, Nm) per camera
    cov = loss.coverage(counts, np.array([True, True, False]))
    assert np.allclose(cov.explained[:2], [0.8, 0.3]) and np.isnan(cov.explained[2])
    assert np.allclose(cov.covered[:2], [80 / 90, 30 / 35])
    assert cov.lowest() == (pytest.approx(0.3), pytest.approx(30 / 35))
    assert loss.fails(cov, loss.LossLevels(0.55, 0.55))  # camera 2 explains 30 % of its mask
    assert not loss.fails(cov, loss.LossLevels(0.25, 0.55))
    assert not loss.fails(loss.coverage(counts[:1], np.array([True])), loss.LossLevels(0.55, 0.55))



def test_clutter_lowers_a_cameras_explained_level_from_the_first_frame():
    counts = np.array([[80, 20, 5], [45, 55, 4], [40, 60, 40], [0, 0, 0]])  # (Nc, Ns, Nm)
    first = loss.coverage(counts, np.array([True, True, True, False]))
    levels = loss.clutter_levels(first, loss.LossLevels(0.60, 0.70))
    # camera 0 explains 0.80 (kept at 0.60); camera 1 0.45 with the body on the silhouette
    # (covered 0.92): a chair, so 0.35; camera 2's model lies half off the mask: not clutter
    assert levels.explained == pytest.approx((0.60, 0.35, 0.60, 0.60)) and levels.covered == 0.70
    later = loss.coverage(np.array([[78, 22, 5], [42, 58, 4], [70, 30, 10], [0, 0, 0]]),
                          np.array([True, True, True, False]))
    assert loss.fails(later, loss.LossLevels(0.60, 0.70)) and not loss.fails(later, levels)
    blown = loss.coverage(np.array([[5, 95, 0], [80, 20, 5]]), np.array([True, True]))
    assert loss.clutter_levels(blown).explained == (loss.CLUTTER_FLOOR, 0.60)  # never switched off
    with pytest.raises(IPFError, match="loss levels for 4 cameras, the frame has 2"):
        loss.fails(blown, levels)  # e.g. a resumed run whose calibration lost cameras


@pytest.fixture(scope="module")
def scene():
    """Six walking frames, then three where the silhouettes are a box nothing like a body."""
    cams = syn.ring_cameras(2, width=160, height=120, focal_px=150)
    q = syn.procedural_walk(9, shape=SHAPE)
    masks = syn.render_masks(q, SHAPE, cams)
    masks[6:] = False
    masks[6:, :, 30:100, 50:110] = True
    return cams, q, masks


def test_a_lost_track_is_written_as_missing_with_its_best_guess(scene, tmp_path, monkeypatch):
    cams, q, masks = scene
    resets = []  # the window sizes are forgotten after each search: the start and the recovery
    reset = Scorer.reset_windows
    monkeypatch.setattr(Scorer, "reset_windows", lambda self: (resets.append(self.evaluations), reset(self)))
    res = track(MemoryDataset(cams, masks, fps=20.0), tmp_path, SETTINGS, progress=False)
    run = json.loads((tmp_path / "run.json").read_text())
    statuses = [r["status"] for r in run["per_frame"]]
    assert statuses[:6] == ["init"] + ["tracked"] * 5  # the walk passes the test
    assert all(r["coverage"]["explained"][0] > 0.55 for r in run["per_frame"][:6])
    assert statuses[6] == "tracked"  # one failing frame is not yet a loss...
    assert statuses[7:] == ["lost", "lost"]  # ... two are, and nothing explains a box
    assert run["frames"]["lost"] == 2
    assert run["loss_levels"] == {"explained": [0.6, 0.6], "covered": 0.7}  # the walk is clutter-free
    assert np.isnan(res.joints[7:]).all() and np.isfinite(res.joints[:7]).all()
    rows = (tmp_path / "poses.csv").read_text().splitlines()
    assert rows[8].split(",")[2:] == ["nan"] * 31
    guess = run["per_frame"][7]["best_guess"]
    assert len(guess["pose"]) == 31 and np.isfinite(guess["points"]).all()
    rec = run["recovery"]
    assert rec["attempts"] == 1 and rec["evaluations"] > 0  # retried only after --recovery-retry
    attempt = rec["per_attempt"][0]
    assert attempt["frame"] == 7 and attempt["trigger"] == "loss test"
    assert attempt["stage"] in ("local", "global")  # the local one failed: the global one ran too
    assert run["per_frame"][7]["recovery"]["evaluations"] == attempt["evaluations"]
    assert 0 < attempt["seconds"] <= run["per_frame"][7]["seconds"]  # timed within its frame
    assert run["seconds"]["recovery"] == attempt["seconds"]
    assert run["init_evaluations"] > rec["evaluations"]  # the recovery is counted in it too
    assert len(resets) == 2 and resets[1] - resets[0] > rec["evaluations"]  # after the recovery
    # gait analysis reads them as gaps and says so
    notes = read_joints_csv(tmp_path / "joints.csv").notes
    assert any("2 frames the tracker declared lost (run.json: frames 7-8)" in n for n in notes)


def test_without_the_loss_test_nothing_is_lost(scene, tmp_path):
    cams, q, masks = scene
    track(MemoryDataset(cams, masks, fps=20.0), tmp_path, SETTINGS._replace(loss_test=False),
          progress=False)
    run = json.loads((tmp_path / "run.json").read_text())
    assert "lost" not in [r["status"] for r in run["per_frame"]]
    assert run["recovery"]["attempts"] == 0 and "coverage" not in run["per_frame"][0]



@pytest.mark.parametrize("posture", ["sit", "crouch"])
def test_local_recovery_finds_a_posture_from_a_standing_pose(posture):
    """The last good pose stands; the person now sits (crouches) there: the local stage finds it."""
    cams = syn.ring_cameras(3, width=160, height=120, focal_px=150)
    truth = place_on_floor(posture_pose(*POSTURES_DEG[posture], heading=0.6), SHAPE.values, U)
    truth[:2] = (0.2, -0.1)
    masks = list(syn.render_masks(truth[None], SHAPE, cams)[0])
    obs = make_observation(masks)
    scorer = Scorer(cams, SHAPE, U, chunk=256)

    def measure(p, shape=None):
        return weights_from_counts(scorer.counts(p, obs), obs.active)[0]

    def still_lost(p):
        return loss.fails(loss.coverage(scorer.counts(p[None], obs)[0], obs.active))

    standing = place_on_floor(gait_pose(5, 5, 5, 5, heading=0.9), SHAPE.values, U)
    standing[:2] = (0.1, 0.0)
    assert still_lost(standing)
    res = recover(np.array([0, 7], np.uint32), masks, cams, U, load_limits(), SHAPE, measure,
                  still_lost, standing, global_settings=FAST_INIT)
    best = res.particles[np.nanargmax(res.weights)]
    assert res.stage == "local" and not still_lost(best)
    knee = np.rad2deg(best[DOF_INDEX["left_knee_flexion"]])
    assert knee > 60, knee  # a bent-knee posture, not a standing one
    if posture == "sit":  # a local result no heavier than ``beat`` (the estimate) goes on
        more = recover(np.array([0, 7], np.uint32), masks, cams, U, load_limits(), SHAPE, measure,
                       still_lost, standing, global_settings=FAST_INIT, beat=np.inf)
        assert more.evaluations > res.evaluations  # the global search ran too
        assert np.nanmax(more.weights) >= np.nanmax(res.weights)  # and the heavier result is kept


def test_posture_grid_puts_the_bodys_centroid_over_the_floor_point():
    """A seated body's root is behind its silhouette's centroid: the posture grid moves each
    configuration so that its capsules' centroid, not its root, is over the floor point."""
    from ipf_jax.tracking.initialise import body_centroid, grid_particles

    foot = np.array([0.4, -0.3, 0.0])
    sit = posture_pose(*POSTURES_DEG["sit"])
    grid = grid_particles(foot, SHAPE, U, load_limits(), FAST_INIT, configs=[sit], centred=True)
    assert len(grid) == FAST_INIT.headings
    for q in grid:
        np.testing.assert_allclose(body_centroid(q, SHAPE.values, U)[:2], foot[:2], atol=1e-6)
    roots = grid[:, :2] - foot[:2]
    assert np.all(np.hypot(*roots.T) > 0.1)  # the root is well behind: the thighs reach forward


def test_initialisation_finds_a_seated_person():
    """The first frame shows someone seated: the postures beyond walking seed the search."""
    from ipf_jax.tracking.initialise import initialise

    cams = syn.ring_cameras(3, width=160, height=120, focal_px=150)
    truth = place_on_floor(posture_pose(*POSTURES_DEG["sit"], heading=-1.0), SHAPE.values, U)
    masks = list(syn.render_masks(truth[None], SHAPE, cams)[0])
    obs = make_observation(masks)
    scorer = Scorer(cams, SHAPE, U, chunk=256)

    def measure(p, shape=None):
        if shape is not None:
            scorer.set_shape(shape)
        return weights_from_counts(scorer.counts(p, obs), obs.active)[0]

    limits = load_limits()
    res = initialise(np.array([0, 3], np.uint32), masks, cams, U, limits, SHAPE, measure,
                     fixed_shape=SHAPE, settings=FAST_INIT._replace(posture_modes=1))
    best = res.particles[np.nanargmax(res.weights)]
    for dof in ("left_hip_flexion", "right_hip_flexion", "left_knee_flexion", "right_knee_flexion"):
        assert np.rad2deg(best[DOF_INDEX[dof]]) > 60, dof
    heading_error = np.rad2deg(abs((best[3] - truth[3] + np.pi) % (2 * np.pi) - np.pi))
    assert heading_error < 30  # facing the right way, not seated backwards
    assert np.hypot(*(best[:2] - truth[:2])) < 0.1
    walking_only = initialise(np.array([0, 3], np.uint32), masks, cams, U, limits, SHAPE, measure,
                              fixed_shape=SHAPE, settings=FAST_INIT)
    assert np.nanmax(res.weights) > np.nanmax(walking_only.weights)
