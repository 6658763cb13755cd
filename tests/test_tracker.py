"""The tracking loop on a tiny self-rendered scene: files, missing frames, determinism, resume."""
import json

import numpy as np
import pytest

from ipf_jax.body import default_shape
from ipf_jax.data.dataset import MemoryDataset
from ipf_jax.data.runfiles import JOINT_COLUMNS, POSE_COLUMNS
from ipf_jax.tracking.initialise import InitSettings
from ipf_jax.tracking.tracker import TrackSettings, track
from ipf_jax.tracking.shape_fit import ShapeFitSettings
from ipf_jax.viz import synthetic as syn

SHAPE = default_shape(1.75)
FAST_INIT = InitSettings(headings=8, position_steps=0, heights_m=(1.75,), modes=1, keep=8,
                         refine_rounds=1, refine_particles=64, pattern_keep=2, pattern_sweeps=1)
SETTINGS = TrackSettings(filter="ipf", filter_options={"top_m": 4}, resolution=160, init=FAST_INIT, chunk=128,
                         checkpoint_every=2, shape_fit=ShapeFitSettings(frames=0))


@pytest.fixture(scope="module")
def scene():
    cams = syn.ring_cameras(2, width=160, height=120, focal_px=150)
    q = syn.procedural_walk(6, shape=SHAPE)
    masks = syn.render_masks(q, SHAPE, cams)
    masks[3, :] = False  # nobody in any camera on frame 3
    masks[4, 1] = False  # camera 2 sees nobody on frame 4
    return cams, q, masks


def test_run_directory_contents(scene, tmp_path):
    cams, q, masks = scene
    res = track(MemoryDataset(cams, masks, fps=20.0), tmp_path, SETTINGS, progress=False)
    lines = (tmp_path / "joints.csv").read_text().splitlines()
    assert lines[0] == ",".join(JOINT_COLUMNS) and len(lines) == 7
    assert (tmp_path / "poses.csv").read_text().splitlines()[0] == ",".join(POSE_COLUMNS)
    assert lines[4].split(",")[2] == "nan"  # frame 3 is missing, not invented
    run = json.loads((tmp_path / "run.json").read_text())
    assert run["up_axis"] == "+z" and run["fps"] == 20.0
    assert run["evaluations_per_frame"] == 4 * 81
    statuses = [r["status"] for r in run["per_frame"]]
    assert statuses[0] == "init" and statuses[3] == "missing"
    assert run["per_frame"][4]["skipped_cameras"] == ["Camera2"]
    assert run["frames"]["missing"] == 1
    assert np.isnan(res.joints[3]).all() and np.isfinite(res.joints[[0, 1, 2, 4, 5]]).all()
    # the CPU XLA compiled for: another instruction set may round the geometry otherwise
    assert set(run["host_cpu"]) == {"model", "vector_isa"} and run["host_cpu"]["model"]


def test_same_seed_same_files(scene, tmp_path):
    cams, q, masks = scene
    ds = MemoryDataset(cams, masks, fps=20.0)
    track(ds, tmp_path / "a", SETTINGS, progress=False)
    track(ds, tmp_path / "b", SETTINGS._replace(chunk=64), progress=False)
    for name in ("joints.csv", "poses.csv"):
        assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "b" / name).read_bytes()


@pytest.mark.parametrize("name,options", [("ipf", {"top_m": 4}), ("fipf", {"top_m": 2, "points_per_dof": 2}),
                                          ("apf", {"particles": 200, "layers": 2})])
def test_draws_made_ahead_are_used_and_change_nothing(scene, tmp_path, name, options):
    """The tracker dispatches the next frames' draws once a frame is measured: every tracked frame's
    step gets them, and the files are byte for byte those of a run that draws inside the step."""
    from ipf_jax.tracking.tracker import Tracker

    cams, q, masks = scene
    ds = MemoryDataset(cams, masks, fps=20.0)
    settings = SETTINGS._replace(filter=name, filter_options=options)
    given = []

    def watch(f):
        def step(key, state, measure, **drawn):
            given.append("drawn" in drawn)
            return f.step(key, state, measure, **drawn)
        return f._replace(step=step)

    ahead = Tracker(ds, settings)
    ahead.filter_hook = watch
    ahead.run(tmp_path / "ahead", progress=False)
    assert given == [True] * 4  # frames 1, 2, 4, 5 (3 is missing: 4's are drawn after it)
    inside = Tracker(ds, settings)
    inside.filter_hook = lambda f: watch(f._replace(draws=None))
    inside.run(tmp_path / "inside", progress=False)
    assert given[4:] == [False] * 4
    for file in ("joints.csv", "poses.csv"):
        assert (tmp_path / "ahead" / file).read_bytes() == (tmp_path / "inside" / file).read_bytes()


def test_the_next_frame_is_read_on_a_background_thread_and_changes_nothing(scene, tmp_path, monkeypatch):
    """Frame t + 1 is read (masks, resize, blobs, rays) while frame t is tracked, on the reader
    thread; the files are byte for byte those of a run that reads every frame when it starts."""
    import threading

    from ipf_jax.tracking import prefetch

    cams, q, masks = scene
    readers = []

    class Watched(MemoryDataset):
        def masks(self, frame):
            readers.append((frame, threading.current_thread().name))
            return super().masks(frame)

    ds = Watched(cams, masks, fps=20.0)
    track(ds, tmp_path / "ahead", SETTINGS, progress=False)
    assert {f for f, name in readers if name.startswith("ipf-jax-read")} == {1, 2, 3, 4, 5}
    readers.clear()
    monkeypatch.setattr(prefetch.Prefetch, "start", lambda self, frame: None)  # read when needed
    track(ds, tmp_path / "direct", SETTINGS, progress=False)
    assert not any(name.startswith("ipf-jax-read") for _, name in readers)
    for file in ("joints.csv", "poses.csv"):
        assert (tmp_path / "ahead" / file).read_bytes() == (tmp_path / "direct" / file).read_bytes()


def test_prefetch_serves_its_frame_raises_its_error_there_and_drops_the_rest():
    from ipf_jax.errors import IPFError
    from ipf_jax.tracking.prefetch import Prefetch

    def read(frame):
        if frame == 3:
            raise IPFError(f"frame {frame} is corrupt")
        return frame * 10

    with Prefetch(read) as ahead:
        ahead.start(1)
        assert ahead.take(1) == 10 and ahead.hits == 1
        ahead.start(3)  # read ahead, failing: nothing is raised until frame 3 is taken
        ahead.start(2)  # another frame asked for instead: the failed read is dropped unraised
        assert ahead.take(2) == 20 and ahead.hits == 2
        assert ahead.take(4) == 40 and ahead.hits == 2  # not read ahead: read directly
        ahead.start(3)
        with pytest.raises(IPFError, match="frame 3 is corrupt"):
            ahead.take(3)
        ahead.start(5)
    # leaving the block waited for the read in flight and dropped it


class Crash(Exception):
    pass


class CrashingDataset(MemoryDataset):
    """Dies while tracking frame ``crash_at``: on reading it right after the frame before (the
    start also reads frames ahead, to see where the person travels, and must not crash)."""
    crash_at = None
    last = None

    def masks(self, frame):
        previous, self.last = self.last, frame
        if self.crash_at is not None and frame == self.crash_at and previous == frame - 1:
            raise Crash()
        return super().masks(frame)


def test_resume_after_a_crash_is_byte_identical(scene, tmp_path):
    cams, q, masks = scene
    full = tmp_path / "full"
    track(MemoryDataset(cams, masks, fps=20.0), full, SETTINGS, progress=False)
    ds = CrashingDataset(cams, masks, fps=20.0)
    ds.crash_at = 5
    with pytest.raises(Crash):
        track(ds, tmp_path / "cut", SETTINGS, progress=False)
    ds.crash_at = None
    track(ds, tmp_path / "cut", SETTINGS, progress=False, resume=True)
    for name in ("joints.csv", "poses.csv"):
        assert (tmp_path / "cut" / name).read_bytes() == (full / name).read_bytes()


def test_a_stop_between_a_frame_and_its_rows_resumes_byte_identical(scene, tmp_path, monkeypatch):
    """Ctrl-C or SIGTERM can land after a frame is tracked and before its rows are counted (here:
    in the draw for the next frame). The state saved is the one before that frame, so --resume
    tracks it again from where the uninterrupted run did (it once resumed from the frame's own
    result and wrote other rows: seen once in CI, SIGTERM at the wrong moment)."""
    from ipf_jax.tracking.tracker import Tracker

    cams, q, masks = scene
    settings = SETTINGS._replace(checkpoint_every=100)
    full = tmp_path / "full"
    track(MemoryDataset(cams, masks, fps=20.0), full, settings, progress=False)
    draw_ahead = Tracker.draw_ahead

    def stop_after_frame_4(self, state, frames):
        if frames[:1] == (5,):  # frame 4 is measured, its draws for frames 5 and 6 are due
            raise KeyboardInterrupt
        return draw_ahead(self, state, frames)

    monkeypatch.setattr(Tracker, "draw_ahead", stop_after_frame_4)
    with pytest.raises(KeyboardInterrupt):
        track(MemoryDataset(cams, masks, fps=20.0), tmp_path / "cut", settings, progress=False)
    monkeypatch.setattr(Tracker, "draw_ahead", draw_ahead)
    run = json.loads((tmp_path / "cut" / "run.json").read_text())
    assert run["frames"]["done"] == 4  # frame 4 was tracked, its rows not counted yet
    track(MemoryDataset(cams, masks, fps=20.0), tmp_path / "cut", settings, progress=False, resume=True)
    for name in ("joints.csv", "poses.csv"):
        assert (tmp_path / "cut" / name).read_bytes() == (full / name).read_bytes()


def test_an_input_error_mid_run_keeps_every_frame_done_resumable(scene, tmp_path):
    """A bad frame stops the run with one error; the frames before it, also those after the last
    periodic checkpoint, are saved (checkpoint and run.json): a resume does not redo them."""
    from ipf_jax.data import checkpoint
    from ipf_jax.errors import IPFError

    class BadFrame(CrashingDataset):
        def masks(self, frame):
            if self.crash_at is not None and frame == self.crash_at:
                raise IPFError(f"corrupt mask on frame {frame}", "FG1/image.png")
            return MemoryDataset.masks(self, frame)

    cams, q, masks = scene
    full = tmp_path / "full"
    track(MemoryDataset(cams, masks, fps=20.0), full, SETTINGS._replace(checkpoint_every=100), progress=False)
    ds = BadFrame(cams, masks, fps=20.0)
    ds.crash_at = 5
    settings = SETTINGS._replace(checkpoint_every=100)  # no periodic checkpoint before the error
    with pytest.raises(IPFError, match=r"corrupt mask on frame 5 \(at frame 5; rows written so far are "
                                       r"kept: fix it and rerun with --resume\)"):
        track(ds, tmp_path / "cut", settings, progress=False)
    assert (tmp_path / "cut" / checkpoint.NAME).exists()
    run = json.loads((tmp_path / "cut" / "run.json").read_text())
    assert run["frames"]["done"] == 5 and [r["frame"] for r in run["per_frame"]] == [0, 1, 2, 3, 4]
    ds.crash_at = None
    res = track(ds, tmp_path / "cut", settings, progress=False, resume=True)
    assert res.run["init_evaluations"] == json.loads((full / "run.json").read_text())["init_evaluations"]
    for name in ("joints.csv", "poses.csv"):
        assert (tmp_path / "cut" / name).read_bytes() == (full / name).read_bytes()


def test_spliced_records_are_the_json_text_of_the_whole_document():
    """run.json and the checkpoint splice their per-frame records, encoded once each, into the
    document: the text is what json writes for the whole document, at every size."""
    from ipf_jax.data.runfiles import EncodedList, dumps

    records = []
    encoded = EncodedList()
    for k in range(4):
        doc = {"a": 1, "per_frame": list(records), "nested": {"x": [1, 2, {"y": None}]},
               "z": "\u00e9", "w": float("nan")}
        for indent in (None, 1, 2):
            want = json.dumps(doc, indent=indent)
            assert dumps({**doc, "per_frame": encoded.update(tuple(records))}, indent) == want
        records.append({"frame": k, "info": {"status": "tracked", "q": [0.5, np.float64(-1.25)]},
                        "empty": [], "none": None, "text": "a\nb \"c\""})
        records[-1]["info"]["q"][1] = float(records[-1]["info"]["q"][1])
    other = [{"frame": 9}]  # not the records held: encoded anew
    assert dumps({"per_frame": encoded.update(other)}) == json.dumps({"per_frame": other})
    assert dumps([1, {"a": [2]}], 1) == json.dumps([1, {"a": [2]}], indent=1)  # not a dict: as is


def test_result_files_are_readable_like_the_users_other_files(tmp_path):
    import os

    from ipf_jax.data.runfiles import write_json_atomic

    umask = os.umask(0o022)
    try:
        write_json_atomic(tmp_path / "run.json", {"a": 1})
    finally:
        os.umask(umask)
    assert (tmp_path / "run.json").stat().st_mode & 0o777 == 0o644  # not mkstemp's 0600


def test_weights_carry_the_pelvis_prior(scene):
    """Every weight the tracker computes is the silhouette likelihood times the level-pelvis prior
    (0: the likelihood alone)."""
    from ipf_jax.body.model import DOF_INDEX
    from ipf_jax.tracking.prior import level_pelvis
    from ipf_jax.tracking.tracker import Tracker

    cams, q, masks = scene
    ds = MemoryDataset(cams, masks, fps=20.0)
    particles = np.repeat(q[:1], 5, axis=0)
    particles[:, DOF_INDEX["root_roll"]] = np.deg2rad([0, 5, -10, 20, 40])
    plain = Tracker(ds, SETTINGS._replace(pelvis_prior_deg=0.0))
    level = Tracker(ds, SETTINGS._replace(pelvis_prior_deg=20.0))
    obs = plain.observe(0).obs
    w0 = plain.measure(obs, SHAPE)(particles)
    w20 = level.measure(obs, SHAPE)(particles)
    assert np.all(w0 > 0) and np.allclose(w20, w0 * level_pelvis(particles, 20.0), rtol=1e-12)
    factors = level_pelvis(particles, 20.0)
    assert factors[0] == 1.0 and np.isclose(factors[3], np.exp(-0.5))  # 20 deg: one sigma
    assert np.all(np.diff(factors) < 0)  # |roll| grows along the particles
    assert np.all(level_pelvis(particles, 0.0) == 1.0)


#: the compiled lean prior (float32) against its NumPy reference (float64): factors in (0, 1]
FACTOR_ATOL = 1e-5


def test_one_camera_weights_carry_the_lean_prior_and_several_do_not(scene):
    """With one camera every weight is the likelihood times the prior against leaning along its
    line of sight; a lean across it costs nothing; with two cameras the prior is off."""
    from ipf_jax.body.model import DOF_INDEX
    from ipf_jax.tracking.prior import lean_angles, upright_reference, upright_to_camera
    from ipf_jax.tracking.tracker import Tracker

    cams, q, masks = scene
    one = MemoryDataset(cams[:1], masks[:, :1], fps=20.0)
    plain = Tracker(one, SETTINGS._replace(lean_prior_deg=0.0))
    upright = Tracker(one, SETTINGS._replace(lean_prior_deg=10.0))
    particles = np.repeat(q[:1], 4, axis=0)
    particles[1:, DOF_INDEX["trunk_flexion"]] += np.deg2rad([5.0, 10.0, 20.0])
    obs = plain.observe(0).obs
    w0 = plain.measure(obs, SHAPE)(particles)
    w10 = upright.measure(obs, SHAPE)(particles)
    factors = upright_to_camera(particles, SHAPE.values, upright.U, upright.cameras[0].centre, 10.0)
    assert np.all(w0 > 0) and np.allclose(w10, w0 * factors, rtol=1e-12)
    assert np.all(factors <= 1.0) and np.all(upright_to_camera(particles, SHAPE.values, upright.U,
                                                                upright.cameras[0].centre, 0.0) == 1)
    # the compiled float32 kernel against the float64 NumPy reference, one body and a body each
    reference = upright_reference(particles, SHAPE.values, upright.U, upright.cameras[0].centre, 10.0)
    np.testing.assert_allclose(factors, reference, atol=FACTOR_ATOL)
    bodies = np.tile(np.asarray(SHAPE.values), (len(particles), 1))
    np.testing.assert_allclose(upright_to_camera(particles, bodies, upright.U, upright.cameras[0].centre,
                                                 10.0), reference, atol=FACTOR_ATOL)

    # a body leaning by 10 deg straight away from the camera, then across its line of sight
    centre = upright.cameras[0].centre
    body = np.zeros((2, len(q[0])))
    body[:, :3] = q[0, :3]
    vertical = upright.U[:, 2]
    away = body[0, :3] - centre
    away -= (away @ vertical) * vertical
    canon = upright.U.T @ away  # the canonical frame: z up, yaw about z
    body[0, DOF_INDEX["root_yaw"]] = np.arctan2(canon[1], canon[0])  # facing away from the camera
    body[1, DOF_INDEX["root_yaw"]] = body[0, DOF_INDEX["root_yaw"]] + np.pi / 2  # side on
    level = lean_angles(body, SHAPE.values, upright.U, centre)
    body[:, DOF_INDEX["root_pitch"]] = np.deg2rad(10.0)  # pitched forward
    pitched = lean_angles(body, SHAPE.values, upright.U, centre)
    for a, b in zip(pitched, level):  # trunk, legs: 10 deg more along the line of sight only
        assert np.allclose(np.rad2deg(a - b), [10.0, 0.0], atol=0.2)
    assert np.allclose(np.rad2deg(level[0][1]), 0.0, atol=0.2)  # side on: nothing along it
    two = Tracker(MemoryDataset(cams, masks, fps=20.0), SETTINGS._replace(lean_prior_deg=10.0))
    none = Tracker(MemoryDataset(cams, masks, fps=20.0), SETTINGS._replace(lean_prior_deg=0.0))
    obs2 = two.observe(0).obs
    assert np.array_equal(two.measure(obs2, SHAPE)(particles), none.measure(obs2, SHAPE)(particles))


def test_lean_prior_edge_cases():
    """The lean prior: no underflow to 0 with a small sigma, 0 for a particle with NaNs, faded out
    for a camera straight above the person, whole for one looking across."""
    from ipf_jax.body.model import DOF_INDEX
    from ipf_jax.tracking.prior import upright_reference, upright_to_camera

    up = np.eye(3)
    body = np.zeros((3, len(DOF_INDEX)))
    body[:, 2] = 1.0
    body[:, DOF_INDEX["root_pitch"]] = 0.5  # 29 deg
    body[2, 5] = np.nan
    across = np.array([5.0, 0.0, 1.0])
    f = upright_to_camera(body, SHAPE.values, up, across, 1.0)
    assert 0.0 < f[0] < 1e-100 and f[2] == 0.0  # float32 would give 0; NaNs give no weight
    np.testing.assert_allclose(f[:2], upright_reference(body[:2], SHAPE.values, up, across, 1.0), rtol=1e-3)
    above = np.array([0.0, 0.0, 4.0])  # straight above the hips: no line of sight to lean along
    assert np.all(upright_to_camera(body[:2], SHAPE.values, up, above, 10.0) == 1.0)
    steep = np.array([2.0, 0.0, 5.0])  # 63 deg below the horizon: partly faded
    full = np.array([3.0, 0.0, 4.0])
    f_steep, f_full = (upright_to_camera(body[:1], SHAPE.values, up, c, 10.0)[0] for c in (steep, full))
    assert f_full < f_steep < 1.0


def test_the_shape_fit_scores_carry_the_prior(scene):
    """What the shape fit scores (``shape_measure``) is the likelihood times the scene's prior."""
    from ipf_jax.tracking.shape_fit import shape_measure
    from ipf_jax.tracking.tracker import Tracker

    cams, q, masks = scene
    tr = Tracker(MemoryDataset(cams[:1], masks[:, :1], fps=20.0), SETTINGS._replace(lean_prior_deg=10.0))
    obs = tr.observe(0).obs
    particles = np.repeat(q[:1], 3, axis=0)
    particles[1:, 3] += [0.1, 0.3]
    bodies = np.tile(np.asarray(SHAPE.values, np.float32), (3, 1))
    plain = shape_measure(tr.scorer, obs)(particles, bodies)
    halved = shape_measure(tr.scorer, obs, lambda p, b: np.full(len(p), 0.5))(particles, bodies)
    np.testing.assert_array_equal(halved, 0.5 * plain)
    prior = tr.fit_scene().prior
    assert prior is not None
    np.testing.assert_allclose(shape_measure(tr.scorer, obs, prior)(particles, bodies),
                               plain * prior(particles, bodies), rtol=1e-12)
    assert np.all(plain > 0)


def test_a_start_pose_is_scored_in_a_block_as_the_frames_are(scene, tmp_path, monkeypatch):
    """Given a start pose, its one-pose call runs padded on the block program the filter's calls
    use (no program of one chunk loaded for it alone); the files are those of an unpadded run."""
    from ipf_jax.likelihood import scorer as likelihood
    from ipf_jax.tracking.tracker import Tracker

    cams, q, masks = scene
    ds = MemoryDataset(cams, masks[:3], fps=20.0)
    settings = SETTINGS._replace(init_pose=q[0], height_m=1.75, chunk=64)
    blocks = []
    program = likelihood._geometry_calls_jit

    def geometry(block, *args, **static):
        blocks.append(block.shape[0])
        return program(block, *args, **static)

    monkeypatch.setattr(likelihood, "_geometry_calls_jit", geometry)
    padded = Tracker(ds, settings)
    assert padded.scorer.block > 1  # IPF's 324 particles a frame in chunks of 64: in blocks
    padded.run(tmp_path / "padded", progress=False)
    frame_blocks = padded.scorer._spread(padded.scorer._blocks(324))  # halved for its threads
    assert blocks[0] == frame_blocks[0][2]  # the start pose: one block of the frames', padded
    blocks.clear()
    plain = Tracker(ds, settings)
    plain.measure = lambda obs, shape=None, log=None, pad=False: Tracker.measure(plain, obs, shape,
                                                                                   log)  # no padding
    plain.run(tmp_path / "plain", progress=False)
    assert blocks[0] == 1  # unpadded: a program of one chunk
    for file in ("joints.csv", "poses.csv"):
        assert (tmp_path / "padded" / file).read_bytes() == (tmp_path / "plain" / file).read_bytes()
