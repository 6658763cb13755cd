"""Properties of the rasteriser and the likelihood over generated capsules, masks and poses.

Rasteriser (exact integer arithmetic, so exact equalities): the JAX scanline and dense kernels and
the NumPy reference agree pixel for pixel; counts stay within their bounds; growing every radius
only adds pixels; mirroring the capsule records mirrors the pixels; an upside-down camera (the
same camera turned 180 degrees about its axis) sees the image turned 180 degrees. Likelihood: never
negative, and a model identical to the mask scores the maximum, ``|mask|``.

Images are 40x30 to 80x60. The JAX kernels are compiled once, at 80x60, and run on smaller
images through their dynamic height and width (as the scorer runs cameras of several sizes),
so the examples cost no recompiles. Generated capsules stay within a fifth of the image's long
side of it, inside every guard band involved, so clipping never makes the compared sides differ.

Examples are derandomised (the same in every CI run); ``IPF_JAX_HYPOTHESIS_EXAMPLES=2000`` runs a
larger, random search.
"""
from __future__ import annotations

import functools
import os

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from ipf_jax.body import default_shape
from ipf_jax.body.model import DOF_INDEX
from ipf_jax.geometry.camera import Camera
from ipf_jax.geometry.capsule2d import CAP_FIELDS, capsule_outline
from ipf_jax.geometry.world import up_rotation
from ipf_jax.likelihood.model_mask import model_mask
from ipf_jax.likelihood.raster import Roi, dense_counts, pack_rows, scanline_counts
from ipf_jax.likelihood.scorer import weights_from_counts
from ipf_jax.reference import likelihood as ref
from ipf_jax.reference.raster import counts_from_caps
from ipf_jax.viz import synthetic as syn

H_MAX, W_MAX = 60, 80  # the compiled size; every image fits in it
N_WORDS = -(-W_MAX // 32)
SEGMENTS = 5  # capsules per set (fewer are padded with undrawn ones)
BATCH = 6  # capsule sets per compiled call
SIZES = [(30, 40), (45, 64), (60, 80), (48, 52)]  # (H, W)

_EXPLORE = int(os.environ.get("IPF_JAX_HYPOTHESIS_EXAMPLES", "0"))
PROPERTY = settings(max_examples=_EXPLORE or 30, deadline=None, derandomize=not _EXPLORE,
                    database=None, suppress_health_check=[HealthCheck.too_slow])


# --- the kernels, compiled once ---------------------------------------------------------------

@functools.lru_cache(maxsize=None)
def _kernel(name: str):
    fn = scanline_counts if name == "scanline" else dense_counts

    def one(caps, words, height, width):
        nc, model = fn(caps, words, Roi(jnp.int32(0), jnp.int32(0)), H_MAX, N_WORDS, 8, W_MAX,
                       height, width)
        return jnp.stack([nc, model])

    return jax.jit(jax.vmap(one, in_axes=(0, None, None, None)))


def kernel_counts(name: str, caps: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """(N, S, 15) records on an (H, W) mask -> (N, 3) int64 (Nc, Ns, Nm) by a JAX kernel."""
    h, w = mask.shape
    words = np.zeros((H_MAX, N_WORDS), np.uint32)
    words[:h] = pack_rows(mask, N_WORDS)
    out = []
    for start in range(0, len(caps), BATCH):
        block = caps[start:start + BATCH]
        padded = np.concatenate([block, np.repeat(block[:1], BATCH - len(block), 0)])
        got = np.asarray(_kernel(name)(jnp.asarray(padded), jnp.asarray(words), jnp.int32(h),
                                       jnp.int32(w)))[:len(block)].astype(np.int64)
        out.append(got)
    nc, model = np.concatenate(out).T
    return np.stack([nc, int(mask.sum()) - nc, model - nc], -1)


def reference_counts(caps: np.ndarray, mask: np.ndarray) -> np.ndarray:
    return np.array([counts_from_caps(c, mask) for c in caps], np.int64)


# --- strategies -------------------------------------------------------------------------------

@st.composite
def scenes(draw, max_sets: int = BATCH, max_radius: float = 0.2):
    """(H, W), capsule discs (N, S): c0, r0, c1, r1, drawn, and an (H, W) bool mask."""
    h, w = draw(st.sampled_from(SIZES))
    long_side = max(h, w)
    margin = 0.2 * long_side
    n = draw(st.integers(1, max_sets))
    k = draw(st.integers(1, SEGMENTS))
    x = st.floats(-margin, w - 1 + margin, allow_nan=False)
    y = st.floats(-margin, h - 1 + margin, allow_nan=False)
    r = st.floats(0.0, max_radius * long_side, allow_nan=False)

    def arr(strategy, shape):
        return np.array(draw(st.lists(strategy, min_size=int(np.prod(shape)),
                                      max_size=int(np.prod(shape)))), np.float64).reshape(shape)

    c0 = np.stack([arr(x, (n, k)), arr(y, (n, k))], -1)
    c1 = np.stack([arr(x, (n, k)), arr(y, (n, k))], -1)
    nested = np.array(draw(st.lists(st.booleans(), min_size=n * k, max_size=n * k))).reshape(n, k)
    c1 = np.where(nested[..., None], c0 + 0.25, c1)  # one disc (nearly) inside the other
    r0, r1 = arr(r, (n, k)), arr(r, (n, k))
    drawn = np.array(draw(st.lists(st.booleans(), min_size=n * k, max_size=n * k))).reshape(n, k)
    drawn[:, 0] = True  # at least one visible capsule per set
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    mask = rng.random((h, w)) < draw(st.sampled_from([0.0, 0.05, 0.3, 0.7, 1.0]))
    if draw(st.booleans()):  # a silhouette-like block as well as the noise
        r_0, c_0 = rng.integers(0, h), rng.integers(0, w)
        mask[r_0:r_0 + h // 2, c_0:c_0 + w // 3] = True
    return (h, w), (c0, r0, c1, r1, drawn), mask


def records(discs) -> np.ndarray:
    """Disc arrays (N, k) -> (N, SEGMENTS, 15) float32 records, padded with undrawn capsules."""
    c0, r0, c1, r1, drawn = discs
    caps = capsule_outline(np, c0, r0, c1, r1, drawn)
    pad = np.zeros(caps.shape[:1] + (SEGMENTS - caps.shape[1], CAP_FIELDS), np.float32)
    return np.concatenate([caps, pad], axis=1)


def mirror(caps: np.ndarray, size: int, axis: int) -> np.ndarray:
    """(snapped, mirrored) records: snapped to 1/1024 px (so ``size - 1 - v`` is exact in
    float32), then mirrored across the image's vertical (axis 0: x -> W-1-x) or horizontal
    (axis 1) centre line, corners reordered (T0+ T0- T1- T1+ -> T0- T0+ T1+ T1-) so the inside
    stays on the same side of every edge."""
    snapped = (np.round(caps.astype(np.float64) * 1024) / 1024).astype(np.float32)
    out = snapped.copy()
    for field in (0, 3) + tuple(range(6, 14, 2)):
        out[..., field + axis] = np.float32(size - 1) - snapped[..., field + axis]
    corners = out[..., 6:14].reshape(*out.shape[:-1], 4, 2)[..., [1, 0, 3, 2], :]
    out[..., 6:14] = corners.reshape(*out.shape[:-1], 8)
    return snapped, out


# --- rasteriser -------------------------------------------------------------------------------

@PROPERTY
@given(scenes())
def test_scanline_dense_and_reference_agree_and_counts_are_bounded(scene):
    (h, w), discs, mask = scene
    caps = records(discs)
    expected = reference_counts(caps, mask)
    np.testing.assert_array_equal(kernel_counts("scanline", caps, mask), expected)
    np.testing.assert_array_equal(kernel_counts("dense", caps, mask), expected)
    nc, ns, nm = expected.T
    model = np.array([model_mask(c, h, w).sum() for c in caps])
    assert np.all(nc >= 0) and np.all(ns >= 0) and np.all(nm >= 0)
    assert np.all(nc <= np.minimum(mask.sum(), model))
    np.testing.assert_array_equal(nc + ns, mask.sum())
    np.testing.assert_array_equal(nc + nm, model)
    assert np.all(model <= h * w)


@PROPERTY
@given(scenes(max_radius=0.15), st.floats(0.5, 3.0))
def test_growing_every_radius_only_adds_pixels(scene, grow):
    (h, w), (c0, r0, c1, r1, drawn), mask = scene
    small = records((c0, r0, c1, r1, drawn))
    big = records((c0, r0 + grow, c1, r1 + grow, drawn))
    for a, b in zip(small, big):
        before, after = model_mask(a, h, w), model_mask(b, h, w)
        assert not np.any(before & ~after), "a pixel left the model when its radii grew"
    got_small, got_big = kernel_counts("scanline", small, mask), kernel_counts("scanline", big, mask)
    assert np.all(got_big[:, 0] >= got_small[:, 0])  # Nc
    assert np.all(got_big[:, 0] + got_big[:, 2] >= got_small[:, 0] + got_small[:, 2])  # |model|


@PROPERTY
@given(scenes(), st.sampled_from([0, 1]))
def test_mirrored_records_give_mirrored_pixels(scene, axis):
    (h, w), discs, mask = scene
    caps, flipped = mirror(records(discs), (w, h)[axis], axis)
    flipped_mask = mask[:, ::-1] if axis == 0 else mask[::-1, :]
    for a, b in zip(caps, flipped):
        m = model_mask(a, h, w)
        np.testing.assert_array_equal(model_mask(b, h, w), m[:, ::-1] if axis == 0 else m[::-1, :])
    expected = reference_counts(caps, mask)
    for name in ("scanline", "dense"):
        np.testing.assert_array_equal(kernel_counts(name, flipped, flipped_mask), expected)


# --- likelihood -------------------------------------------------------------------------------

@PROPERTY
@given(scenes())
def test_a_model_identical_to_the_mask_scores_the_maximum(scene):
    (h, w), discs, _ = scene
    caps = records(discs)
    mask = model_mask(caps[0], h, w)
    assume(mask.any())
    counts = kernel_counts("scanline", caps, mask)
    w_all, _ = weights_from_counts(counts[:, None, :], np.array([True]))
    assert np.all(w_all >= 0) and np.all(np.isfinite(w_all))
    assert w_all[0] == mask.sum() == w_all.max()
    # ties only where the model misses nothing and adds at most one pixel (w = Nc / max(Ns+Nm, 1))
    tied = w_all == w_all[0]
    assert np.all(counts[tied, 1] == 0) and np.all(counts[tied, 2] <= 1)


@PROPERTY
@given(st.lists(st.tuples(st.integers(0, 10**6), st.integers(0, 10**6), st.integers(0, 10**6)),
                min_size=1, max_size=6),
       st.lists(st.booleans(), min_size=1, max_size=6))
def test_weights_are_never_negative_and_skip_inactive_cameras(per_camera, active):
    n_cam = min(len(per_camera), len(active))
    counts = np.array(per_camera[:n_cam])[None]  # (1, C, 3)
    active = np.array(active[:n_cam])
    w, w_cam = weights_from_counts(counts, active)
    assert np.all(np.isnan(w_cam[:, ~active])) and np.all(w_cam[:, active] >= 0)
    if active.any():
        assert w[0] >= 0 and w[0] == pytest.approx(np.mean(w_cam[0, active]))
    else:
        assert np.isnan(w[0])


SHAPE = default_shape(1.75)
UP = up_rotation("+z")


def upside_down(cam: Camera) -> Camera:
    """The same camera turned 180 degrees about its optical axis: pixel (u, v) -> (W-1-u, H-1-v).
    Camera x and y change sign, so the tangential distortion terms do as well."""
    flip = np.diag([-1.0, -1.0, 1.0])
    K = cam.K.copy()
    K[0, 2], K[1, 2] = cam.width - 1 - K[0, 2], cam.height - 1 - K[1, 2]
    dist = cam.dist * np.array([1, 1, -1, -1, 1])
    return Camera(K=K, dist=dist, R=flip @ cam.R, T=flip @ cam.T, width=cam.width,
                  height=cam.height, name=cam.name + "_upside_down")


@settings(PROPERTY, max_examples=(_EXPLORE // 10) or 10)
@given(st.integers(0, 5), st.sampled_from(SIZES), st.floats(-0.2, 0.2), st.floats(-0.002, 0.002),
       st.integers(0, 2**32 - 1))
def test_upside_down_camera_sees_the_image_turned(frame, size, k1, p, seed):
    h, w = size
    cam = syn.ring_cameras(1, width=w, height=h, focal_px=0.9 * w, radius=4.0)[0]
    cam = Camera(K=cam.K, dist=np.array([k1, 0.0, p, -p, 0.0]), R=cam.R, T=cam.T, width=w,
                 height=h, name="cam")
    q = syn.procedural_walk(6, shape=SHAPE)[frame]
    rng = np.random.default_rng(seed)
    poses = np.repeat(q[None], 4, axis=0)
    poses[1:, 6:] += rng.normal(0, 0.2, (3, poses.shape[1] - 6))
    mask = syn.render_masks(q[None], SHAPE, [cam])[0, 0] | (rng.random((h, w)) < 0.05)
    straight = ref.counts(poses, SHAPE.values, UP, [cam], [mask])
    turned = ref.counts(poses, SHAPE.values, UP, [upside_down(cam)], [mask[::-1, ::-1]])
    # float64 geometry, mirrored up to rounding; a coordinate rounded across a 1/8 px step moves
    # at most a few boundary pixels
    assert np.abs(straight - turned).max() <= 4, (straight, turned)
    assert straight[0, 0, 0] > 0  # the person is in view: the check is not vacuous


@settings(PROPERTY, max_examples=(_EXPLORE // 10) or 10)
@given(st.integers(0, 5), st.lists(st.floats(-0.3, 0.3), min_size=3, max_size=3))
def test_rendering_pose_scores_the_maximum_through_the_cameras(frame, offsets):
    cams = syn.ring_cameras(2, width=80, height=60, focal_px=75, radius=4.0)
    q = syn.procedural_walk(6, shape=SHAPE)[frame]
    masks = list(syn.render_masks(q[None], SHAPE, cams)[0])
    others = np.repeat(q[None], 3, axis=0)
    bent = [DOF_INDEX[d] for d in ("left_hip_flexion", "right_knee_flexion", "left_shoulder_flexion")]
    others[:, bent] += np.array(offsets)
    counts = ref.counts(np.concatenate([q[None], others]), SHAPE.values, UP, cams, masks)
    active = np.array([m.any() for m in masks])
    w, _ = weights_from_counts(counts, active)
    assert np.all(w >= 0)
    assert w[0] == np.mean([m.sum() for m, a in zip(masks, active) if a]) == w.max()


@PROPERTY
@given(calls=st.lists(st.integers(1, 5000), min_size=1, max_size=16),
       limit=st.sampled_from([64, 128, 512, 1000]))
def test_the_chunk_picked_for_a_filter_is_never_worse_than_the_default(calls, limit):
    """Host-only: :func:`pick_chunking` stays within its range and never raises the modelled cost;
    its calls cover every particle."""
    from ipf_jax.likelihood.scorer import MAX_CALL_CHUNKS, Chunking, call_blocks, chunk_cost, pick_chunking
    got = pick_chunking(calls, limit)
    c, b = got
    assert 1 <= c <= limit and 1 <= b <= MAX_CALL_CHUNKS and b & (b - 1) == 0
    base = chunk_cost(calls, Chunking(limit))
    assert chunk_cost(calls, got) <= base
    assert got == Chunking(limit) or (c % 8 == 0 and chunk_cost(calls, got) <= 0.9 * base)
    for n in calls:
        assert sum(call_blocks(n, got)) * c >= n > (sum(call_blocks(n, got)) - 1) * c


@PROPERTY
@given(n_win=st.integers(1, 64), data=st.data())
def test_the_row_list_holds_each_capsule_inside_its_window(n_win, data):
    """Host-only: :func:`row_list` puts each capsule's own rows, in order, at rows ``skip ..`` of
    a window of ``n_win`` entries that lies inside the list, in no more entries than windows slid
    up over their capsules took before (every row from the window's first listed)."""
    from ipf_jax.likelihood.scorer import list_need, row_list
    n_seg = data.draw(st.integers(1, 17))
    count = np.array(data.draw(st.lists(st.integers(0, n_win), min_size=n_seg, max_size=n_seg)))
    skip = np.array([data.draw(st.integers(0, n_win - c)) if c else 0 for c in count])
    win_rows = np.array(data.draw(st.lists(st.integers(0, 200), min_size=n_seg, max_size=n_seg)))
    need = list_need(skip, count, n_win)
    slid = skip + count
    assert max(n_win, count.sum()) <= need <= slid.sum() - slid.max() + n_win
    rows = row_list(win_rows, skip, count, n_win, need + data.draw(st.integers(0, 9)))
    assert np.all(rows.first >= 0) and np.all(rows.first + n_win <= len(rows.seg))
    for s in range(n_seg):
        k = slice(rows.first[s] + skip[s], rows.first[s] + skip[s] + count[s])
        assert np.all(rows.seg[k] == s)
        np.testing.assert_array_equal(rows.row[k], win_rows[s] + skip[s] + np.arange(count[s]))


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), turn=st.floats(-np.pi, np.pi), n=st.integers(1, 70))
def test_lean_angles_turn_with_the_scene_and_the_compiled_prior_matches(seed, turn, n):
    """The one-camera lean prior reads the lean along the camera's line of sight: turning the body
    and the camera together about the vertical changes neither angle; the compiled float32 factors
    (padded calls of any length) agree with the float64 NumPy reference."""
    from ipf_jax.tracking.prior import lean_angles, upright_reference, upright_to_camera

    rng = np.random.default_rng(seed)
    values = np.asarray(default_shape(1.7).values, float)
    up = up_rotation("+z")
    q = rng.normal(0.0, 0.25, (n, len(DOF_INDEX)))
    q[:, :2] = rng.uniform(-2.0, 2.0, (n, 2))
    q[:, 2] = 1.0
    centre = np.array([6.0, -4.0, 1.5])
    c, s = np.cos(turn), np.sin(turn)
    rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    turned = q.copy()
    turned[:, :3] = q[:, :3] @ rot.T
    turned[:, DOF_INDEX["root_yaw"]] += turn
    before = lean_angles(q, values, up, centre)
    after = lean_angles(turned, values, up, rot @ centre)
    for a, b in zip(before, after):
        np.testing.assert_allclose(a, b, atol=1e-9)
    reference = upright_reference(q, values, up, centre, 10.0)
    np.testing.assert_allclose(upright_to_camera(q, values, up, centre, 10.0), reference, atol=1e-5)


@settings(PROPERTY)
@given(n=st.integers(1, 300), per_particle=st.booleans(), seed=st.integers(0, 2**16))
def test_padded_particles_keep_every_particle_and_pad_with_the_first(n, per_particle, seed):
    """The host layout of the particle-last kernels: the rows kept are the particles in order
    (float32), the padding copies the first particle (and its body), the length a power of two;
    inside a kernel ``rows_of`` puts the particle axis last."""
    from ipf_jax.geometry.kinematics import MIN_BLOCK, padded_particles, rows_of

    rng = np.random.default_rng(seed)
    q = rng.normal(size=(n, 31))
    sv = rng.uniform(0.05, 0.5, size=(n, 7) if per_particle else (7,))
    qp, svp, kept = padded_particles(q, sv)
    block = qp.shape[0]
    assert kept == n and block >= max(n, MIN_BLOCK) and block & (block - 1) == 0
    assert block < 2 * max(n, MIN_BLOCK)
    assert qp.dtype == np.float32 and np.array_equal(qp[:n], q.astype(np.float32))
    assert np.array_equal(qp[n:], np.repeat(qp[:1], block - n, axis=0))
    if per_particle:
        assert svp.shape == (block, 7) and np.array_equal(svp[:n], sv.astype(np.float32))
        assert np.array_equal(svp[n:], np.repeat(svp[:1], block - n, axis=0))
    else:
        assert np.array_equal(svp, sv.astype(np.float32))
    q_t, sv_t = rows_of(jnp.asarray(qp), jnp.asarray(svp))
    assert np.array_equal(np.asarray(q_t), qp.T)
    assert np.array_equal(np.asarray(sv_t), svp.T if per_particle else svp)


@settings(PROPERTY)
@given(values=st.lists(st.floats(allow_nan=True, allow_infinity=True, width=64), min_size=1, max_size=60),
       decimals=st.integers(0, 9))
def test_run_rows_are_formatted_as_numpy_scalars_format_them(values, decimals):
    """A run CSV's values, formatted from Python floats for speed, read exactly as NumPy's float64
    scalars formatted them before (``nan`` for every value that is not finite; -0.0, ties, huge and
    tiny values included)."""
    from ipf_jax.data.runfiles import _fmt

    x = np.array(values, np.float64)
    numpy_scalars = ",".join("nan" if not np.isfinite(v) else f"{v:.{decimals}f}" for v in x)
    assert _fmt(x, decimals) == numpy_scalars
    assert _fmt(x.reshape(-1, 1), decimals) == numpy_scalars  # (J, 3) points are written raveled


@settings(PROPERTY)
@given(values=st.lists(st.floats(0.0, 1e3, allow_nan=False) | st.just(float("nan")), min_size=1,
                       max_size=40))
def test_the_confidence_median_is_numpys(values):
    """The tracker's median of its last weights is ``np.median``'s number (NaN when one is NaN)."""
    from ipf_jax.tracking.tracker import median

    expected = float(np.median(values))
    got = median(values)
    assert got == expected or (np.isnan(got) and np.isnan(expected))
