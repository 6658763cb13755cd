"""The batched scorer: agreement with the NumPy pipeline, chunk/ROI invariance, weight rules."""
import itertools

import numpy as np
import pytest

from ipf_jax.body import default_shape
from ipf_jax.geometry.world import up_rotation
from ipf_jax.likelihood.scorer import Scorer, make_observation, weights_from_counts
from ipf_jax.reference import likelihood as ref
from ipf_jax.viz import synthetic as syn

SHAPE = default_shape()
U = up_rotation("+z")


def make_scene():
    """2 synthetic cameras (160x120), 6 rendered frames, 40 particles around the pose of frame 2."""
    cams = syn.ring_cameras(2, width=160, height=120, focal_px=150)
    q = syn.procedural_walk(6, shape=SHAPE)
    masks = syn.render_masks(q, SHAPE, cams)
    rng = np.random.default_rng(0)
    particles = np.repeat(q[2:3], 40, axis=0)
    particles[1:, 6:] += rng.normal(0, 0.15, size=(39, 25))
    particles[1:, :3] += rng.normal(0, 0.05, size=(39, 3))
    return cams, q, masks, particles


@pytest.fixture(scope="module")
def scene():
    return make_scene()


def test_scorer_matches_numpy_pipeline(scene):
    cams, q, masks, particles = scene
    obs = make_observation(list(masks[2]))
    got = Scorer(cams, SHAPE, U, chunk=16).counts(particles, obs)
    want = ref.counts(particles, SHAPE.values, U, cams, list(masks[2]))
    # float32 vs float64 geometry may move a boundary pixel; counts agree to a few pixels
    assert np.abs(got - want).max() <= 3
    assert np.mean(got == want) > 0.9


def test_true_pose_scores_highest_and_exactly(scene):
    cams, q, masks, particles = scene
    obs = make_observation(list(masks[2]))
    counts = Scorer(cams, SHAPE, U, chunk=16).counts(particles, obs)
    w, _ = weights_from_counts(counts, obs.active)
    assert np.argmax(w) == 0  # particle 0 is the rendering pose
    assert np.all(counts[0, :, 1:] <= 2)  # model == mask up to float32-vs-float64 boundary pixels


def test_chunking_and_roi_do_not_change_counts(scene):
    cams, q, masks, particles = scene
    obs = make_observation(list(masks[3]))
    a = Scorer(cams, SHAPE, U, chunk=7).counts(particles, obs)
    b = Scorer(cams, SHAPE, U, chunk=16).counts(particles, obs)
    c = Scorer(cams, SHAPE, U, chunk=16).counts(particles, obs, full_roi=True)
    d = Scorer(cams, SHAPE, U, chunk=16, kernel="dense").counts(particles, obs)
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(b, c)
    np.testing.assert_array_equal(b, d)
    small = Scorer(cams, SHAPE, U, chunk=32)
    small.set_small_chunks((4, 8))  # 40 = 32 + a call of 8
    assert [small.block_size(n) for n in (40, 8, 5, 3)] == [32, 8, 8, 4]
    np.testing.assert_array_equal(small.counts(particles, obs), b)
    np.testing.assert_array_equal(small.counts(particles[:3], obs), b[:3])
    # a call's chunks in compiled calls of `block` chunks, the rest one per call
    n = len(particles)
    assert n == 40 and Scorer(cams, SHAPE, U, chunk=7)._blocks(n) == [(i, min(7, n - i), 1, 7)
                                                                      for i in range(0, n, 7)]
    four = Scorer(cams, SHAPE, U, chunk=7, block=4)
    assert four._blocks(n) == [(0, 28, 4, 7), (28, 7, 1, 7), (35, 5, 1, 7)]
    np.testing.assert_array_equal(four.counts(particles, obs), b)
    np.testing.assert_array_equal(four.counts(particles, obs, full_roi=True), b)
    np.testing.assert_array_equal(Scorer(cams, SHAPE, U, chunk=7, block=4, kernel="dense").counts(
        particles, obs), b)
    assert Scorer(cams, SHAPE, U, chunk=5, block=8)._blocks(n) == [(0, 40, 8, 5)]  # one call
    assert small._blocks(40) == [(0, 32, 1, 32), (32, 8, 1, 8)]


def test_a_padded_call_runs_its_last_chunks_in_one_more_block(scene):
    """``counts(pad=True)``: the chunks after a call's whole blocks run in one more block (the
    block's program) instead of one chunk per call; counts equal."""
    cams, q, masks, particles = scene
    obs = make_observation(list(masks[3]))
    want = Scorer(cams, SHAPE, U, chunk=7).counts(particles, obs)
    s = Scorer(cams, SHAPE, U, chunk=7, block=4)
    assert s._blocks(40) == [(0, 28, 4, 7), (28, 7, 1, 7), (35, 5, 1, 7)]  # one chunk per call
    assert s._blocks(40, pad=True) == [(0, 28, 4, 7), (28, 12, 4, 7)]  # 6 chunks, 2 of padding
    assert s._blocks(1, pad=True) == [(0, 1, 4, 7)]  # a start pose
    np.testing.assert_array_equal(s.counts(particles, obs, pad=True), want)
    np.testing.assert_array_equal(s.counts(particles[:1], obs, pad=True), want[:1])
    small = Scorer(cams, SHAPE, U, chunk=32)
    small.set_small_chunks((8,))  # small chunks are the shape fit's: not padded
    assert small._blocks(40, pad=False) == [(0, 32, 1, 32), (32, 8, 1, 8)]
    np.testing.assert_array_equal(small.counts(particles, obs, pad=True), want)


def test_threads_run_halved_blocks_side_by_side_with_the_same_counts(scene):
    """``threads``: each block is cut into a part per thread (as if full: a padded block gets the
    parts a full one gets; parts without particles dropped), whose programs and each camera's run
    from several host threads; the counts are those of one thread."""
    from ipf_jax.likelihood import scorer as scorer_mod

    cams, q, masks, particles = scene
    obs = make_observation(list(masks[3]))
    one = Scorer(cams, SHAPE, U, chunk=5, block=8, threads=1)
    assert one._spread(one._blocks(40)) == [(0, 40, 8, 5)]
    want = one.counts(particles, obs)
    three = Scorer(cams, SHAPE, U, chunk=5, block=8, threads=3)
    assert three._spread(three._blocks(40)) == [(0, 15, 3, 5), (15, 15, 3, 5), (30, 10, 3, 5)]
    assert three._spread(three._blocks(1, pad=True)) == [(0, 1, 3, 5)]  # the parts' size
    assert three._spread(three._blocks(12, pad=True)) == [(0, 12, 3, 5)]
    assert three._spread([(0, 3, 2, 5), (10, 5, 1, 5)]) == [(0, 3, 1, 5), (10, 5, 1, 5)]
    before = scorer_mod._counts_jit._cache_size()
    np.testing.assert_array_equal(three.counts(particles, obs), want)
    assert scorer_mod._counts_jit._cache_size() - before <= 2  # one program of 3 chunks a camera
    np.testing.assert_array_equal(three.counts(particles[:12], obs, pad=True), want[:12])
    np.testing.assert_array_equal(
        Scorer(cams, SHAPE, U, chunk=5, block=8, threads=2, kernel="dense").counts(particles, obs),
        want)
    with pytest.raises(Exception, match="threads must be >= 1"):
        Scorer(cams, SHAPE, U, threads=0)


def test_a_call_writes_its_records_into_the_last_calls_buffers(scene):
    """The geometry program writes a block's records into a finished call's buffers, given to it
    (donated: no new set filled with zeros for its loop); the counts are a fresh scorer's, and
    the buffers it was given are gone (XLA used them, JAX warned of none it could not use)."""
    import warnings

    import jax

    cams, q, masks, particles = scene
    scorer = Scorer(cams, SHAPE, U, chunk=8, block=4, threads=2)
    obs = [make_observation(list(masks[f])) for f in (1, 2)]
    scorer.counts(particles, obs[0])
    # 40 particles in chunks of 8: a block of 4 chunks cut into 2 parts (threads), then 1 chunk
    # (a call of one chunk makes its buffers in its program: none kept)
    assert sorted((k, len(v)) for (k, b, _), v in scorer._spare.items()) == [(2, 2)]
    spare = [rec for recs in scorer._spare.values() for rec in recs]
    moved = particles[::-1] + 0.01
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # "Some donated buffers were not usable" would raise
        got = scorer.counts(moved, obs[1])
    assert all(leaf.is_deleted() for rec in spare for leaf in jax.tree.leaves(rec))
    np.testing.assert_array_equal(got, Scorer(cams, SHAPE, U, chunk=8, block=4, threads=2).counts(
        moved, obs[1]))


def test_reset_windows_sizes_them_to_the_next_call(scene):
    """After a wide search the tracker forgets its window sizes: the next call's own need sets
    them (smaller than the wide cloud's), and the counts are those of the whole image."""
    cams, q, masks, particles = scene
    obs = make_observation(list(masks[0]))
    scorer = Scorer(cams, SHAPE, U, chunk=16)
    wide = particles + np.random.default_rng(0).normal(0, 0.3, size=particles.shape)
    scorer.counts(wide, obs)
    big = scorer.sizes
    scorer.reset_windows()
    got = scorer.counts(particles[:4], obs)
    assert all(s.win_rows <= b.win_rows and s.rows <= b.rows for s, b in zip(scorer.sizes, big))
    assert scorer.sizes != big
    np.testing.assert_array_equal(got, Scorer(cams, SHAPE, U, chunk=16).counts(
        particles[:4], obs, full_roi=True))


def test_weight_rules():
    counts = np.array([[[100, 0, 0], [50, 10, 40]], [[0, 100, 30], [0, 0, 0]]])
    w, w_cam = weights_from_counts(counts, np.array([True, True]))
    assert w_cam[0, 0] == 100  # identical model and mask: w = Nc
    assert w_cam[0, 1] == pytest.approx(1.0)
    assert w[0] == pytest.approx(50.5)
    w, w_cam = weights_from_counts(counts, np.array([True, False]))
    assert np.isnan(w_cam[0, 1]) and w[0] == 100
    w, _ = weights_from_counts(counts, np.array([False, False]))
    assert np.all(np.isnan(w))


def test_empty_mask_camera_is_inactive(scene):
    cams, q, masks, _ = scene
    obs = make_observation([masks[0, 0], np.zeros_like(masks[0, 1])])
    assert obs.active.tolist() == [True, False]


def test_model_partly_outside_the_image_is_exact(scene):
    """Windows hold every visible pixel also when the body leaves the image or the camera."""
    cams, q, masks, particles = scene
    moved = particles.copy()
    moved[:, 0] += np.linspace(-3.0, 3.0, len(moved))  # sideways: out of view at both ends
    moved[::7, 2] += 2.5  # some far above
    obs = make_observation(list(masks[2]))
    windowed = Scorer(cams, SHAPE, U, chunk=16).counts(moved, obs)
    full = Scorer(cams, SHAPE, U, chunk=16).counts(moved, obs, full_roi=True)
    np.testing.assert_array_equal(windowed, full)
    assert np.any(windowed[:, :, 0] == 0) and np.any(windowed[:, :, 0] > 0)


def test_windows_hold_every_capsule(scene):
    cams, q, masks, particles = scene
    scorer = Scorer(cams, SHAPE, U, chunk=16)
    _, ext = scorer.geometry(particles)
    win = scorer.plan(ext)
    n_win, n_win_words, n_rows, n_words = (np.array(v)[:, None] for v in list(zip(*scorer.sizes))[:4])
    h, w = scorer.heights[:, None], scorer.widths[:, None]
    seen = (ext[..., 0] < h) & (ext[..., 1] >= 0) & (ext[..., 2] < w) & (ext[..., 3] >= 0)
    top, bottom = np.clip(ext[..., 0], 0, h - 1), np.clip(ext[..., 1], 0, h - 1)
    left, right = np.clip(ext[..., 2], 0, w - 1) // 32, np.clip(ext[..., 3], 0, w - 1) // 32
    assert np.all(~seen | ((win.win_rows <= top) & (bottom < win.win_rows + n_win)))
    assert np.all(~seen | ((win.win_words <= left) & (right < win.win_words + n_win_words)))
    row0, word0 = win.row0[:, None], win.word0[:, None]
    assert np.all((row0 <= win.win_rows) & (win.win_rows + n_win <= row0 + n_rows))
    assert np.all((word0 <= win.win_words) & (win.win_words + n_win_words <= word0 + n_words))
    assert np.all(row0 + n_rows <= scorer.h_pad) and np.all(word0 + n_words <= scorer.w_words)
    assert np.all(n_win < n_rows)  # the windows are smaller than the model's box
    # the row list: each capsule's entries are its own rows, in order, inside its window's R entries
    for c, rows in enumerate(win.rows):
        sz = scorer.sizes[c]
        assert len(rows.seg) == len(rows.row) == sz.list_rows
        assert np.all(rows.first >= 0) and np.all(rows.first + sz.win_rows <= sz.list_rows)
        assert np.all(rows.skip + rows.count <= sz.win_rows)
        for s in range(len(rows.first)):
            k = slice(rows.first[s] + rows.skip[s], rows.first[s] + rows.skip[s] + rows.count[s])
            assert np.all(rows.seg[k] == s)
            np.testing.assert_array_equal(rows.row[k], win.win_rows[c, s] + rows.skip[s]
                                          + np.arange(rows.count[s]))
            if seen[c, s]:
                assert win.win_rows[c, s] + rows.skip[s] == top[c, s]
                assert win.win_rows[c, s] + rows.skip[s] + rows.count[s] - 1 == bottom[c, s]


def test_no_retrace_across_frames(scene):
    """One compile per shape: after the first frame, no stage is traced again."""
    import collections

    import jax

    from ipf_jax.likelihood import scorer as likelihood

    cams, q, masks, particles = scene
    stages = {"_geometry_calls_jit": ("_geometry_calls_impl", ("long_side", "scan_q")),
              "_counts_jit": ("_counts_impl", ("q", "long_side", "sizes", "dense"))}
    traces = collections.Counter()
    saved = {name: getattr(likelihood, name) for name in stages}

    def counted(impl):
        fn = getattr(likelihood, impl)

        def traced(*args, **static):
            traces[impl] += 1
            return fn(*args, **static)
        return traced

    try:
        for pad in (False, True):
            traces.clear()
            for name, (impl, static) in stages.items():
                setattr(likelihood, name, jax.jit(counted(impl), static_argnames=static))
            scorer = Scorer(cams, SHAPE, U, chunk=16, block=2, threads=1)  # blocks kept whole
            obs = make_observation(list(masks[0]))
            scorer.counts(particles, obs, pad=pad)  # warm-up: window sizes
            first = dict(traces)
            # 40 particles in chunks of 16: a call of 2 chunks and one of 1 (K = 2 and 1), or
            # padded two calls of 2; the counts' also per camera when the two cameras' window
            # sizes differ
            programs = 1 if pad else 2
            assert first["_geometry_calls_impl"] == programs
            assert programs <= first["_counts_impl"] <= 2 * programs
            rng = np.random.default_rng(1)
            for i in range(1, 6):  # new masks and a moving cloud, as in tracking
                moved = particles + rng.normal(0, 0.003, size=particles.shape)
                scorer.counts(moved, make_observation(list(masks[i])), pad=pad)
            assert dict(traces) == first
    finally:
        for name, fn in saved.items():
            setattr(likelihood, name, fn)


def test_chunk_sizes_follow_the_filters_calls():
    """IPF's one call of 6561 gets 16 chunks of 416 in one compiled call (the same 6656 particles
    as 13 chunks of 512, in one call instead of 13); the factored filter's 14 calls of 1017, 648,
    216 and 72 particles (M 8, no polish) get chunks of 216, which pad 6,912 particles instead of
    11,264; with its default polish (M 7: calls of 1332, 567, 189 and 63, then 6 x (62, 1)) chunks
    of 72 in blocks of 8, which pad 7,272 instead of 17,920."""
    from ipf_jax.body.limits import load_limits
    from ipf_jax.filters import registry
    from ipf_jax.likelihood.scorer import Chunking, call_blocks, pick_chunking
    limits = load_limits("default")
    make = lambda name: registry.make(name, {}, limits, 20.0, budget=6561)  # noqa: E731
    assert pick_chunking(make("ipf").calls) == Chunking(416, 16)
    assert call_blocks(6561, Chunking(416, 16)) == [16]
    assert call_blocks(6561, Chunking(512, 8)) == [8, 1, 1, 1, 1, 1]
    assert call_blocks(6561, Chunking(512)) == [1] * 13
    fipf = registry.make("fipf", {"polish": 0}, limits, 20.0, budget=6561)
    assert pick_chunking(fipf.calls).chunk == 216
    assert sum(-(-n // 216) * 216 for n in fipf.calls) == 6912
    assert sum(-(-n // 512) * 512 for n in fipf.calls) == 11264
    polished = make("fipf")
    assert pick_chunking(polished.calls) == Chunking(72, 8)
    assert sum(-(-n // 72) * 72 for n in polished.calls) == 7272
    assert sum(-(-n // 512) * 512 for n in polished.calls) == 17920
    assert pick_chunking([6561], chunk=512).chunk == 512  # --chunk: only the block is chosen


def test_window_buckets_come_from_a_fixed_ladder():
    """Sizes are rungs (multiples of the step, >= 25 % apart, ending at the cap); they grow to
    the rung that holds the need and shrink only when asked (a new frame)."""
    from ipf_jax.likelihood.scorer import _bucket, _ladder
    rungs = _ladder(8, 240)
    assert rungs[0] == 8 and rungs[-1] == 240 and all(r % 8 == 0 for r in rungs)
    assert all(b >= a + max(8, a // 4) for a, b in zip(rungs[:-2], rungs[1:-1]))
    assert _bucket(0, 50, 8, 240) == 56  # the smallest rung holding 50
    assert _bucket(56, 30, 8, 240) == 56  # within a frame: never smaller
    assert _bucket(120, 30, 8, 240, shrink=True) == 32
    assert _bucket(56, 50, 8, 240, shrink=True) == 56
    assert _bucket(56, 500, 8, 240) == 240  # capped at the image


def test_new_frame_shrinks_windows_after_a_wide_search_and_keeps_counts(scene):
    """A wide spread (an initialisation) grows the windows; once SHRINK_FRAMES frames have needed
    less, new_frame gives smaller ones, and their counts equal those of the whole image."""
    from ipf_jax.likelihood.scorer import SHRINK_FRAMES
    cams, q, masks, particles = scene
    obs = make_observation(list(masks[1]))
    scorer = Scorer(cams, SHAPE, U, chunk=16)
    wide = particles.copy()
    wide[:, 0] += np.linspace(-0.8, 0.8, len(wide))
    scorer.counts(wide, obs)
    big = scorer.sizes
    narrow = np.repeat(particles[:1], 16, axis=0)
    for _ in range(SHRINK_FRAMES):  # the wide frame is among the last ones: nothing shrinks
        scorer.new_frame()
        assert scorer.sizes == big
        scorer.counts(narrow, obs)
    scorer.new_frame()  # now every remembered frame is a narrow one
    assert all(s.win_rows <= b.win_rows and s.rows <= b.rows for s, b in zip(scorer.sizes, big))
    assert scorer.sizes != big
    got = scorer.counts(narrow, obs)
    np.testing.assert_array_equal(got, Scorer(cams, SHAPE, U, chunk=16).counts(narrow, obs, full_roi=True))


def test_a_block_geometry_equals_its_chunks_one_by_one(scene):
    """The block program runs the forward kinematics and projection on all its chunks at once and
    the row coefficients chunk by chunk (the records alone block-wide): every record and extent
    equals K one-chunk calls', for one body and for a body per particle (the shape fit's
    candidates), with the scanline kernel's row coefficients and with the records alone."""
    import jax

    from ipf_jax.likelihood import scorer as sc

    cams, q, masks, particles = scene
    s = Scorer(cams, SHAPE, U, chunk=8)
    block = particles.reshape(5, 8, -1).astype(np.float32)
    rng = np.random.default_rng(1)
    bodies = (np.asarray(SHAPE.values, np.float32) * rng.uniform(0.9, 1.1, (5, 8, len(SHAPE.values)))
              ).astype(np.float32)
    for sv, scan_q in itertools.product((np.asarray(SHAPE.values, np.float32), bodies), (s.q, 0)):
        recs, ext = sc._geometry_calls_jit(block, sv, s.up, s.cams, None, long_side=s.long_side,
                                           scan_q=scan_q)
        ones = [sc._geometry_jit(block[k], sv if sv.ndim == 1 else sv[k], s.up, s.cams,
                                 long_side=s.long_side, scan_q=scan_q) for k in range(5)]
        for k, (rec_k, ext_k) in enumerate(ones):
            for got, want in zip(jax.tree.leaves(recs), jax.tree.leaves(rec_k)):
                np.testing.assert_array_equal(np.asarray(got)[k], np.asarray(want))
        every = np.stack([np.asarray(e) for _, e in ones])
        np.testing.assert_array_equal(ext, np.stack([every[..., 0].min(0), every[..., 1].max(0),
                                                     every[..., 2].min(0), every[..., 3].max(0)], -1))


RECORD_TOL_PX = 1e-4  # two compiled forms of the same float32 geometry


def test_the_records_alone_block_wide_or_chunk_by_chunk_are_the_same(scene, monkeypatch):
    """The records alone go block-wide up to ``BLOCK_WIDE_BYTES`` and chunk by chunk beyond: the
    same records and extents either way, to the last bits of a float (the two compiled forms may
    round differently: the records are geometry, held to a tolerance; measured 7.6e-6 px here)."""
    import jax

    from ipf_jax.likelihood import scorer as sc

    cams, q, masks, particles = scene
    s = Scorer(cams, SHAPE, U, chunk=8)
    block = particles.reshape(5, 8, -1).astype(np.float32)
    sv = np.asarray(SHAPE.values, np.float32)
    got = {}
    for limit in (sc.BLOCK_WIDE_BYTES, 0):
        monkeypatch.setattr(sc, "BLOCK_WIDE_BYTES", limit)
        fresh = jax.jit(lambda *a, **k: sc._geometry_calls_impl(*a, **k),  # a new function: traced anew
                        static_argnames=("long_side", "scan_q"), compiler_options=sc.COMPILER_OPTIONS)
        got[limit] = jax.tree.leaves(fresh(block, sv, s.up, s.cams, None, long_side=s.long_side, scan_q=0))
    for wide, chunked in zip(*got.values()):
        np.testing.assert_allclose(np.asarray(wide), np.asarray(chunked), rtol=0, atol=RECORD_TOL_PX)
