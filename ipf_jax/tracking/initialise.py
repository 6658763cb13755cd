"""Automatic initialisation: exhaustive search over a grid of plausible configurations.

As in the paper, the first frame (and any frame where the track is lost) is searched exhaustively
over a grid of plausible configurations, whatever the cameras' orientation:

1. **Where**: each camera's largest silhouette blob gives a viewing ray through its centroid. With
   two or more cameras the rays are intersected (least squares); with one camera the ray meets the
   plane at the body's centroid height (0.55 x height) for each candidate height. The point is
   dropped onto the floor.
2. **Grid**: floor positions around that point x headings over 360 deg x coarse leg/arm
   configurations (:data:`ipf_jax.geometry.posing.LEG_CONFIGS_DEG`) x body heights (when not given), each
   placed with its lowest point on the floor.
3. **Refinement**: the heaviest distinct configurations seed a few rounds of local search with
   shrinking noise on every DOF (the frame is static, so this is a search, not a filter), with a
   final choice among neighbouring heights.

Returns weighted particles that seed the tracking filter, the chosen height, and the number of
likelihood evaluations spent (reported separately from the per-frame budget).
"""
from __future__ import annotations

import itertools
from typing import Callable, NamedTuple

import jax
import numpy as np

from ..body.limits import Limits
from ..body.model import DOF_INDEX, DOF_NAMES, NUM_DOF
from ..body.proportions import within_bounds
from ..body.shape import LENGTH_GROUPS, BodyShape
from ..errors import IPFError
from ..filters.base import gaussian_noise
from ..filters.compass import SEARCH_STD, compass_search
from ..filters.selection import top_distinct
from ..geometry.camera import Camera
from ..geometry.host import forward_kinematics
from ..geometry.placement import floor_point_single
from ..geometry.posing import LEG_CONFIGS_DEG, POSTURES_DEG, gait_pose, place_on_floor, posture_pose
from ..geometry.rays import intersect_rays, is_upright, ray_at_height, silhouette_rays

CENTROID_HEIGHT = 0.55  # fraction of standing height at the body's area centroid


def _group(*prefixes: str) -> np.ndarray:
    return np.array([i for i, n in enumerate(DOF_NAMES) if n.startswith(prefixes)])


#: DOF groups refined one at a time: root + trunk, each leg, each arm, head.
PART_GROUPS = (_group("root", "trunk"), _group("left_hip", "left_knee", "left_ankle"),
               _group("right_hip", "right_knee", "right_ankle"), _group("left_shoulder", "left_elbow"),
               _group("right_shoulder", "right_elbow"), _group("head"))
#: First-round noise std per DOF (m, rad).
REFINE_STD = SEARCH_STD  # the initialisation's random refinement draws at this scale


class InitSettings(NamedTuple):
    headings: int = 16
    position_step_m: float = 0.15
    position_steps: int = 1  # grid of (2k+1)^2 floor positions
    heights_m: tuple[float, ...] = (1.55, 1.65, 1.75, 1.85, 1.95)
    modes: int = 4  # distinct grid modes refined separately
    keep: int = 24
    refine_rounds: int = 4
    refine_particles: int = 384
    pattern_keep: int = 8
    pattern_sweeps: int = 6
    posture_modes: int = 1  # distinct modes of the postures beyond walking refined (0: none)


class InitResult(NamedTuple):
    particles: np.ndarray  # (N, D)
    weights: np.ndarray  # (N,)
    shape: BodyShape  # height and proportions found (or given)
    evaluations: int


def floor_points(masks: list[np.ndarray], cameras: list[Camera], up: np.ndarray,
                 heights: tuple[float, ...]) -> dict[float, np.ndarray]:
    """Candidate floor position (3,) under the person, per candidate height."""
    rays = silhouette_rays(masks, cameras)
    if not rays:
        raise IPFError("no silhouette in any camera: cannot initialise")
    p = intersect_rays(rays)
    if p is not None:
        foot = p - up * (up @ p)
        return {h: foot for h in heights}
    out = {}
    seen = [k for k, m in enumerate(masks) if silhouette_rays([m], [cameras[k]])]
    for h in heights:
        if is_upright(cameras[seen[0]], up):  # feet at the bottom, head at the top of the image
            p = floor_point_single(masks[seen[0]], cameras[seen[0]], up, h)
        else:
            p = ray_at_height(rays[0], up, CENTROID_HEIGHT * h)
        if p is None:
            raise IPFError("the silhouette's viewing ray does not reach the person's height from this "
                           "single camera (level camera or wrong up axis): give --up or --init-pose")
        out[h] = p - up * (up @ p)
    return out


def body_centroid(q: np.ndarray, shape_values: np.ndarray, U: np.ndarray) -> np.ndarray:
    """(3,) area-weighted centre of the capsules' outlines (a capsule's side view: ``2 r l + pi r^2``
    with ``r`` its mean radius), which is where a silhouette's centroid ray passes."""
    pose = forward_kinematics(q, shape_values, U)
    r = pose.seg_r.mean(axis=1)
    area = 2 * r * np.linalg.norm(pose.seg_b - pose.seg_a, axis=1) + np.pi * r**2
    return area @ (0.5 * (pose.seg_a + pose.seg_b)) / area.sum()


def headings(count: int, facing: float | None = None) -> np.ndarray:
    """The grid's headings (rad): ``count`` over 360 deg, or with ``facing`` those of the same step
    within 90 deg of it (``count // 2 + 1``, ``facing`` itself among them)."""
    if facing is None:
        return np.linspace(-np.pi, np.pi, count, endpoint=False)
    step = 2 * np.pi / count
    half = count // 4
    yaw = facing + step * np.arange(-half, half + 1)
    return (yaw + np.pi) % (2 * np.pi) - np.pi


def grid_particles(foot: np.ndarray, shape: BodyShape, U: np.ndarray, limits: Limits,
                   settings: InitSettings, configs: list[np.ndarray] | None = None,
                   centred: bool = False, heading: float | None = None) -> np.ndarray:
    """(G, D) grid configurations standing at positions around ``foot``: ``configs`` (poses at
    the origin, default: the walking ones of ``LEG_CONFIGS_DEG``) x headings x positions.

    ``foot`` is under the silhouettes' centroid. A walking pose's root is over its own centroid;
    a seated or crouching one's is not (the thighs reach forward), so with ``centred`` each
    configuration is moved so that its capsules' centroid, not its root, is over ``foot``.
    ``heading`` (rad): only the headings within 90 deg of it, at the grid's step (a walker facing
    the way they travel, :mod:`ipf_jax.tracking.travel`)."""
    k = settings.position_steps
    offsets = settings.position_step_m * np.arange(-k, k + 1)
    east, north, up = U[:, 0], U[:, 1], U[:, 2]
    out = []
    for config in (configs if configs is not None else [gait_pose(*legs) for legs in LEG_CONFIGS_DEG]):
        base = place_on_floor(config, shape.values, U)  # at the origin, on the floor
        for yaw in headings(settings.headings, heading):
            q = base.copy()
            q[3] = yaw
            shift = np.zeros(3)
            if centred:
                c = body_centroid(q, shape.values, U) - q[:3]
                shift = c - up * (up @ c)
            for dx in offsets:
                for dy in offsets:
                    qq = q.copy()
                    qq[:3] = base[:3] + foot - shift + dx * east + dy * north
                    out.append(qq)
    return limits.clip(np.array(out))


Measure = Callable[[np.ndarray, BodyShape], np.ndarray]


def initialise(rng_key: jax.Array, masks: list[np.ndarray], cameras: list[Camera], U: np.ndarray,
               limits: Limits, base_shape: BodyShape, measure: Measure, *,
               height_m: float | None = None, fixed_shape: BodyShape | None = None,
               settings: InitSettings = InitSettings(), heading: float | None = None) -> InitResult:
    """Search one frame. ``measure(particles, shape) -> weights`` scores on that frame.

    ``height_m`` fixes the height (proportions are still fitted); ``fixed_shape`` fixes the whole
    shape (re-initialisation keeps the subject found at the start). ``heading`` (rad): the walking
    configurations face within 90 deg of it (the direction of travel); the postures beyond walking
    (seated, crouching: nobody travels so) keep every heading.
    """
    if fixed_shape is not None:
        base_shape, height_m = fixed_shape, fixed_shape.height_m
    heights = (height_m,) if height_m is not None else settings.heights_m
    feet = floor_points(masks, cameras, U[:, 2], heights)
    evaluations = 0
    pool_q, pool_w, pool_h = [], [], []
    for h in heights:
        shape = base_shape if h == base_shape.height_m else base_shape.scaled_to(h)
        grid = grid_particles(feet[h], shape, U, limits, settings, heading=heading)
        w = measure(grid, shape)
        evaluations += len(grid)
        pool_q.append(grid)
        pool_w.append(w)
        pool_h.append(np.full(len(w), h))
    q_all, w_all, h_all = map(np.concatenate, (pool_q, pool_w, pool_h))
    search = dict(search_height=height_m is None, search_proportions=fixed_shape is None)
    best = refine_modes(rng_key, q_all, w_all, h_all, base_shape, measure, U, limits, settings,
                        settings.modes, **search)
    evaluations += best.evaluations
    if settings.posture_modes:  # the postures beyond walking, refined beside the walking modes
        q, w, h, n = posture_grid(feet, heights, base_shape, U, limits, measure, settings)
        other = refine_modes(rng_key, q, w, h, base_shape, measure, U, limits, settings,
                             settings.posture_modes, salt=len(q_all), **search)
        evaluations += n + other.evaluations
        if np.nanmax(other.weights) > np.nanmax(best.weights):
            best = other
    return best._replace(evaluations=evaluations)


def posture_grid(feet: dict, heights: tuple[float, ...], base_shape: BodyShape, U: np.ndarray,
                 limits: Limits, measure: Measure, settings: InitSettings):
    """The postures of :data:`ipf_jax.geometry.posing.POSTURES_DEG` at every heading and floor
    position of the grid, for every height: (G, D) particles, (G,) weights, (G,) heights, G."""
    pool_q, pool_w, pool_h = [], [], []
    for h in heights:
        shape = base_shape if h == base_shape.height_m else base_shape.scaled_to(h)
        grid = grid_particles(feet[h], shape, U, limits, settings,
                              configs=[posture_pose(*p) for p in POSTURES_DEG.values()], centred=True)
        pool_q.append(grid)
        pool_w.append(measure(grid, shape))
        pool_h.append(np.full(len(grid), h))
    q, w, h = map(np.concatenate, (pool_q, pool_w, pool_h))
    return q, w, h, len(q)


def refine_modes(rng_key: jax.Array, q_all: np.ndarray, w_all: np.ndarray, h_all: np.ndarray,
                 base_shape: BodyShape, measure: Measure, U: np.ndarray, limits: Limits,
                 settings: InitSettings, modes: int, *, search_height: bool,
                 search_proportions: bool, salt: int = 0) -> InitResult:
    """The refinement of a scored grid: (G, D) configurations, (G,) weights, (G,) heights.

    The silhouettes are ambiguous (heading, which leg is forward): ``modes`` distinct modes of the
    grid are refined separately and the best kept, rather than letting one basin absorb the search.
    Each mode's random key is the grid index plus ``salt``.
    """
    evaluations = 0
    results = []
    for seed_idx in grid_modes(q_all, w_all, modes):
        h = float(h_all[seed_idx])
        seed = (q_all[seed_idx][None], w_all[seed_idx][None])
        key = jax.random.fold_in(rng_key, int(seed_idx) + salt)
        res = _refine(key, *seed, h, base_shape, measure, U, limits, settings,
                      search_height=search_height, search_proportions=search_proportions)
        evaluations += res.evaluations
        results.append(res)
    best = max(results, key=lambda r: np.nanmax(r.weights))
    return best._replace(evaluations=evaluations)


def grid_modes(q: np.ndarray, w: np.ndarray, count: int, min_yaw_deg: float = 45.0) -> list[int]:
    """Indices of up to ``count`` heavy grid configurations that differ in heading (by at least
    ``min_yaw_deg``) or in which leg is forward (sign of the hip flexion difference)."""
    order = np.argsort(-np.where(np.isnan(w), -np.inf, w), kind="stable")
    legs = np.sign(np.round(q[:, DOF_INDEX["left_hip_flexion"]] - q[:, DOF_INDEX["right_hip_flexion"]], 3))
    chosen: list[int] = []
    for i in order:
        distinct = True
        for j in chosen:
            dyaw = np.rad2deg(abs((q[i, 3] - q[j, 3] + np.pi) % (2 * np.pi) - np.pi))
            if dyaw < min_yaw_deg and legs[i] == legs[j]:
                distinct = False
                break
        if distinct:
            chosen.append(int(i))
        if len(chosen) == count:
            break
    return chosen


def _refine(rng_key, particles, weights, h, base_shape, measure, U, limits, settings, *, search_height,
            search_proportions):
    """Partitioned random search, then compass search, from one seed; height refined once,
    then the subject's proportions (legs, arms, trunk) and a last compass search."""
    evaluations = 0
    shape = base_shape if h == base_shape.height_m else base_shape.scaled_to(h)
    # local search, one body part at a time, with shrinking noise (the frame is static, so this
    # is a search, not a filter): perturbing 6 DOF at once finds improvements that 31 at once miss
    reps = max(1, settings.refine_particles // settings.keep)
    for r in range(settings.refine_rounds):
        for g, group in enumerate(PART_GROUPS):
            idx = top_distinct(particles, weights, settings.keep)
            kept, kept_w = particles[idx], weights[idx]
            std = np.zeros(NUM_DOF)
            std[group] = REFINE_STD[group] * 0.75 ** r
            key = jax.random.fold_in(jax.random.fold_in(rng_key, r), g)
            cand = limits.clip(np.repeat(kept, reps, axis=0) + gaussian_noise(key, (len(kept) * reps, NUM_DOF), std))
            w = measure(cand, shape)
            evaluations += len(cand)
            # the kept configurations compete again with their known weights
            particles, weights = np.concatenate([kept, cand]), np.concatenate([kept_w, w])
        if r == settings.refine_rounds // 2 and search_height:
            h, particles, weights, n = _refine_height(particles, weights, base_shape, h, measure, U)
            evaluations += n
            shape = base_shape.scaled_to(h)
    particles, weights, n = limb_grids(particles, weights, measure, shape, limits, keep=settings.pattern_keep)
    evaluations += n
    particles, weights, n = pattern_search(particles, weights, measure, shape, limits,
                                           keep=settings.pattern_keep, sweeps=settings.pattern_sweeps)
    evaluations += n
    if search_proportions:
        shape, particles, weights, n = fit_proportions(particles, weights, shape, measure, U, limits)
        evaluations += n
        particles, weights, n = pattern_search(particles, weights, measure, shape, limits,
                                               keep=settings.pattern_keep, sweeps=3, first_step=0.125)
        evaluations += n
    return InitResult(particles, weights, shape, evaluations)


def fit_proportions(particles, weights, shape: BodyShape, measure, U, limits, *, keep: int = 8,
                    factors=(0.92, 0.96, 1.04, 1.08), passes: int = 2):
    """Coordinate search over segment-group length factors (legs, arms, trunk) on the best
    configurations, feet kept on the floor. People's proportions differ from the default adult by
    several per cent; a wrong leg length alone moves the ankles by centimetres."""
    idx = top_distinct(particles, weights, keep)
    top, best_w = particles[idx], float(np.nanmax(weights))
    current = {g: 1.0 for g in LENGTH_GROUPS}
    base = shape
    best = (shape, particles, weights)
    n = 0
    for _ in range(passes):
        for group in LENGTH_GROUPS:
            for k in factors:
                trial = dict(current, **{group: current[group] * k})
                cand = base.with_factors(**trial)  # a plausible person: inside the bounds
                cand_shape = BodyShape(within_bounds(cand.values), cand.height_m)
                q = np.array([place_on_floor(t, cand_shape.values, U) for t in top])
                w = measure(limits.clip(q), cand_shape)
                n += len(q)
                if np.nanmax(w) > best_w:
                    best_w = float(np.nanmax(w))
                    current = trial
                    best = (cand_shape, q, w)
                    top = q[np.argsort(-w, kind="stable")]
    return (*best, n)


def _limb_grid(*axes: tuple[str, tuple[float, ...]]) -> tuple[np.ndarray, np.ndarray]:
    idx = np.array([DOF_INDEX[name] for name, _ in axes])
    values = np.deg2rad(np.array(list(itertools.product(*[v for _, v in axes]))))
    return idx, values


#: Per-limb exhaustive grids (degrees) searched with the rest of the body held: the thin limbs
#: have narrow likelihood peaks that random moves of the whole body rarely hit.
LIMB_GRIDS = tuple(
    _limb_grid((f"{side}_shoulder_flexion", (-45, -30, -15, 0, 15, 30, 45)),
               (f"{side}_shoulder_abduction", (0, 12, 25)),
               (f"{side}_elbow_flexion", (0, 25, 50, 75, 100)))
    for side in ("left", "right")) + tuple(
    _limb_grid((f"{side}_hip_flexion", (-25, -15, -5, 5, 15, 25, 35)),
               (f"{side}_hip_abduction", (-8, 0, 8)),
               (f"{side}_knee_flexion", (0, 15, 30, 50, 70)))
    for side in ("left", "right"))


def limb_grids(particles, weights, measure, shape, limits, *, keep: int):
    """Each limb's grid (:data:`LIMB_GRIDS`) on the best configurations, the rest held."""
    n = 0
    for idx, values in LIMB_GRIDS:
        top = top_distinct(particles, weights, keep)
        base, base_w = particles[top], weights[top]
        cand = np.repeat(base, len(values), axis=0)
        cand[:, idx] = np.tile(values, (len(base), 1))
        cand = limits.clip(cand)
        w = measure(cand, shape)
        n += len(cand)
        particles = np.concatenate([base, cand])
        weights = np.concatenate([base_w, w])
    return particles, weights, n


def pattern_search(particles, weights, measure, shape, limits, *, keep: int, sweeps: int,
                   first_step: float = 0.5):
    """:func:`~ipf_jax.filters.compass.compass_search` with ``shape`` held, its first steps
    ``first_step`` x :data:`REFINE_STD`. Returns the pooled particles, weights, evaluations."""
    return compass_search(particles, weights, lambda q: measure(q, shape), limits.clip,
                          REFINE_STD * first_step, keep=keep, sweeps=sweeps)


def _refine_height(particles, weights, base_shape, h0, measure, U):
    """Re-score the best configurations at neighbouring heights (feet kept on the floor)."""
    top = particles[top_distinct(particles, weights, 16)]
    best = (h0, particles, weights)
    best_score = np.nanmax(weights)
    n = 0
    for h in (h0 * 0.96, h0 * 0.98, h0 * 1.02, h0 * 1.04):
        shape = base_shape.scaled_to(h)
        q = np.array([place_on_floor(t, shape.values, U) for t in top])
        w = measure(q, shape)
        n += len(q)
        if np.nanmax(w) > best_score:
            best_score = np.nanmax(w)
            best = (h, q, w)
    return (*best, n)
