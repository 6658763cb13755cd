"""Shape calibration: the subject's segment lengths and girths, fitted with the poses of K frames.

One template scaled by height cannot fit a person whose legs are long for the torso, and the
feet-on-the-floor placement then puts every hip too high or too low. This module fits the
subject's proportions (the 15 symmetric groups of :mod:`ipf_jax.body.proportions`: 8 lengths,
the ankle height, 2 breadths, 4 girths and the shoe's, inside anthropometric bounds, hip joint centres placed by the Harrington
rule) jointly with the poses of ``K`` frames spread over the recording, on the exact silhouette
likelihood, without derivatives:

    theta = 0 (the reference shape: the template at the height found on the first frame)
    for round r = 1..R:
        poses: compass search (ipf_jax.tracking.initialise.pattern_search) of every frame's best poses
               with the current shape
        shape: CMA-ES over theta (group log-factors), G generations of lambda candidates;
               a candidate's score is the mean over the K frames of the best of the frame's
               kept poses, each carried over to that candidate's body: moved along the up axis
               so that its lowest point touches the floor (longer legs lift the pelvis), its limb
               angles moved so that the knees, feet, elbows and wrists stay where the current
               body had them (ipf_jax.geometry.retarget), on the floor again; each pose also
               with its joint angles kept (its limbs moving with a changed breadth), the
               better of the two counted
    final compass search of every frame's poses with the best shape

Different poses separate the lengths (a bent knee splits thigh and shank, a swinging arm
upper arm and forearm). Every candidate x pose of a frame is scored in **one** call of the
compiled likelihood with a body per particle (:meth:`ipf_jax.likelihood.scorer.Scorer.counts`
``shapes=``): the shape values are data of the compiled geometry stage, so no candidate
recompiles anything. A given standing height (``dataset.json``'s ``height_m`` or ``--height``)
constrains the fit: every candidate is scaled uniformly to it.

Two entry points:

* :func:`calibrate_at_start` (pass 1): the first frame is initialised as before (heights grid);
  ``K - 1`` more frames spread over the recording are initialised with that shape held (a lighter
  search, :data:`FRAME_INIT`), then the joint fit runs; the tracker starts from the fitted first
  frame.
* :func:`refit_from_track` (pass 2, offline): the poses of a finished track seed the fit on
  ``K`` tracked frames; the recording is then tracked again with that shape held
  (:func:`track_two_pass`).

What one camera can recover: lengths along the image plane and the body's outline (girths seen
edge on, the leg length from the hip height over the floor); not the depth of the body or
breadths seen end on (pelvis and shoulder breadth when the person walks towards or away from
the camera, or side-on: then only one of breadth and depth is seen), and lengths that are
foreshortened in every chosen frame. See docs/shape_fit.md.
"""
from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import NamedTuple

import numpy as np

from ..body.limits import Limits
from ..body.model import NUM_DOF, SEGMENTS, SHAPE_INDEX
from ..body.proportions import (
    BOUNDS,
    GROUP_NAMES,
    GROUPS,
    NUM_GROUPS,
    PRIOR_FACTORS,
    build,
    group_bounds,
    group_factors,
    stature,
)
from ..body.shape import BodyShape
from ..errors import IPFError, require
from ..filters.selection import top_distinct
from ..geometry.kinematics import forward_kinematics
from ..geometry.retarget import limb_points, retarget
from ..likelihood.scorer import SMALL_CHUNKS, Observation, Scorer, weights_from_counts
from .initialise import InitSettings, initialise, pattern_search


class ShapeFitSettings(NamedTuple):
    """frames : K, frames spread over the recording (first one included); 0 = no shape fit.

    rounds : pose / shape alternations.  generations, population : CMA-ES per round.
    sigma : first CMA-ES step, natural-log units (0.04 = 4 %).  pose_keep : distinct poses
    per frame carried into the shape scores.  pose_sweeps : compass sweeps per pose search.
    refit_frames : K of the second pass (frames of the finished track).
    prior : weight of a weak pull towards the prior proportions (the template's, shod ankles:
    :data:`ipf_jax.body.proportions.PRIOR_FACTORS`), as a fraction of the starting score per
    group at its bound (a group the views cannot see stays there rather than drifting with the
    search's noise).  split_prior : the same for the split of a limb between its two segments
    (thigh / shank, upper arm / forearm), which silhouettes barely see: the limb's length is
    fitted, its split kept near the template's unless the poses show otherwise. 10 % at the
    bound; :func:`for_views` lowers it to :data:`FEW_VIEWS_SPLIT_PRIOR` below
    :data:`CARRY_ANGLES_MIN_VIEWS` cameras (measured: docs/shape_fit.md).
    retarget_iterations : Gauss-Newton steps that carry a frame's kept poses over to a candidate
    body with its limb joints kept in place (:mod:`ipf_jax.geometry.retarget`); 0 keeps the
    joint angles, as the fit did before (a shorter thigh then moved the knee and foot of a
    swinging leg).
    carry_angles : also score every kept pose with its joint angles kept (on the floor) and
    count the better of the two carry-overs per pose, when the recording has at least
    :data:`CARRY_ANGLES_MIN_VIEWS` cameras (:func:`for_views`). With the limb joints held in place
    alone, wider shoulders kept the elbows and wrists where the narrower body had put them, so
    the fit could not widen them (the shoulders came out 7-93 mm narrow on every visible walk;
    docs/shape_fit.md).
    foot_bounds : the foot's length group's bounds (lower, upper fractions) in place of
        :data:`ipf_jax.body.proportions.BOUNDS`' ``"foot"``, or None; :func:`for_views` holds it
        to the lengths' +-15 % with fewer than :data:`FOOT_MIN_VIEWS` cameras.
    searches : independent shape searches (the rounds above) from the same start; with more than
    one, the body is the mean of theirs (log factors) and the best one's poses are carried over
    to it. 1 is the default: two cost a third more evaluations and their gain was within the
    seeds' spread (docs/shape_fit.md).
    """

    frames: int = 8  # the default of --shape-frames (measured: docs/shape_fit.md)
    rounds: int = 4
    generations: int = 10
    population: int = 16
    sigma: float = 0.05
    pose_keep: int = 4
    pose_sweeps: int = 3
    refit_frames: int = 10
    prior: float = 1e-3
    split_prior: float = 1e-1
    retarget_iterations: int = 3
    carry_angles: bool = True
    foot_bounds: tuple[float, float] | None = None
    searches: int = 1


#: Fewest cameras for ``carry_angles``. Measured on the visible renders (docs/shape_fit.md): with
#: 4 cameras it lowered the 10 walks' error over seeds 0/1/2 (29.4 -> 27.5 mm); with 2 it raised
#: the 2-camera walks' in 5 of 6 runs (41 -> 51 mm on the mean: arms thickened by the fit and lost
#: by the tracker), with 1 camera 6 of the 8 walks'. With 3 (the 4-camera walks without one:
#: ``benchmarks/accuracy.py --sets walks3``) it lowered the mean over seeds 0/1/2 (33.8 -> 32.4 mm,
#: 17 of 30 runs) but not the legs' offsets (19.8 -> 21.5).
CARRY_ANGLES_MIN_VIEWS = 3


#: Fewest cameras for the foot's length bound of -30 % (``BOUNDS["foot"]``). Measured on the
#: visible renders (docs/shape_fit.md): with 4 cameras it lowered the 10 walks' hip/knee/ankle
#: offset over seeds 0/1/2 (20.7 -> 18.9 mm), with 2 the two-camera walks' error at seed 0 (59.2
#: -> 43.5 mm); with 1 it raised the 8 one-camera walks' at seeds 0 and 1 (135.7 -> 148.1 mm, 10
#: of 16 runs): one view, the fit shortened the foot where the legs were wrong.
FOOT_MIN_VIEWS = 2


#: The limb-split prior's weight below :data:`CARRY_ANGLES_MIN_VIEWS` cameras. Measured on the
#: visible renders (docs/shape_fit.md): 10 % (the default) against 1 % lowered the 10 four-camera
#: walks' error over seeds 0/1/2 (28.0 -> 27.2 mm; the shoulders' constant offset 22.9 -> 18.0 mm,
#: the elbows' 17.0 -> 14.6, the legs' unchanged: the fits' upper arm had drifted up to 10 % long
#: against the forearm, the truth's split is the template's within 3 %), but raised the 8
#: one-camera walks' at seeds 0 and 1 (135.7 -> 144.4 mm, 12 of 16 runs worse). The fits with
#: ``carry_angles`` are the ones it was measured to help.
FEW_VIEWS_SPLIT_PRIOR = 1e-2


def for_views(settings: "ShapeFitSettings", cameras: int) -> "ShapeFitSettings":
    """``settings`` for a recording with ``cameras`` cameras: ``carry_angles`` and the firmer
    limb-split prior need :data:`CARRY_ANGLES_MIN_VIEWS` of them (below:
    :data:`FEW_VIEWS_SPLIT_PRIOR`), the foot's wider length bound :data:`FOOT_MIN_VIEWS`."""
    many = cameras >= CARRY_ANGLES_MIN_VIEWS
    return settings._replace(
        carry_angles=settings.carry_angles and many,
        split_prior=settings.split_prior if many else FEW_VIEWS_SPLIT_PRIOR,
        foot_bounds=settings.foot_bounds if cameras >= FOOT_MIN_VIEWS else BOUNDS["length"])


#: The lighter initialisation of the other K - 1 frames of pass 1 (shape held, so one height).
FRAME_INIT = InitSettings(headings=16, position_steps=1, modes=2, keep=12, refine_rounds=2,
                          refine_particles=192, pattern_keep=4, pattern_sweeps=4)


# -- scoring with a body per particle ---------------------------------------------------------------
ShapeMeasure = Callable[[np.ndarray, np.ndarray], np.ndarray]


def shape_measure(scorer: Scorer, obs: Observation, prior: ShapeMeasure | None = None) -> ShapeMeasure:
    """``fn(particles (N, D), shapes (N, P)) -> (N,)`` weights on one frame, a body per particle,
    times ``prior(particles, shapes)`` when given (the tracker's, :mod:`.prior`)."""
    def fn(particles: np.ndarray, shapes: np.ndarray) -> np.ndarray:
        w = weights_from_counts(scorer.counts(particles, obs, shapes=shapes), obs.active)[0]
        return w if prior is None else w * prior(particles, shapes)
    return fn


def _as_body_measure(fn: ShapeMeasure):
    """The ``measure(particles, BodyShape)`` signature of :mod:`ipf_jax.tracking.initialise`."""
    def measure(particles: np.ndarray, shape: BodyShape) -> np.ndarray:
        return fn(particles, np.broadcast_to(np.asarray(shape.values, np.float32),
                                             (len(particles), len(shape.values))))
    return measure


_R_IDX = np.array([[SHAPE_INDEX[s.r_a], SHAPE_INDEX[s.r_b]] for s in SEGMENTS])


def lowest_heights(q: np.ndarray, values: np.ndarray, U: np.ndarray) -> np.ndarray:
    """(N, D) poses, (N, P) bodies -> (N,) height over the floor of each lowest capsule point."""
    q = np.asarray(q, np.float64)
    v = np.asarray(values, np.float64)
    pose = forward_kinematics(q, v.T[..., None], np.asarray(U, np.float64), xp=np)
    up = np.asarray(U, np.float64)[:, 2]
    r = v[:, _R_IDX]  # (N, S, 2)
    return np.minimum((pose.seg_a @ up - r[..., 0]).min(-1), (pose.seg_b @ up - r[..., 1]).min(-1))


def place_on_floor_many(q: np.ndarray, values: np.ndarray, U: np.ndarray) -> np.ndarray:
    """(N, D) poses moved along up so that each one's lowest point (with its body) is on the floor."""
    q = np.array(q, np.float64)
    q[:, :3] -= np.outer(lowest_heights(q, values, U), np.asarray(U, np.float64)[:, 2])
    return q


# -- CMA-ES (Hansen 2016, "The CMA Evolution Strategy: a tutorial", default parameters) ---------
class CMAES:
    """Minimal CMA-ES minimiser: ``ask() -> (lambda, n)``, ``tell(X, f)``."""

    def __init__(self, x0: np.ndarray, sigma: float, popsize: int, rng: np.random.Generator):
        n = len(x0)
        self.n, self.lam, self.mu = n, int(popsize), int(popsize) // 2
        w = np.log(self.mu + 0.5) - np.log(np.arange(1, self.mu + 1))
        self.w = w / w.sum()
        self.mueff = 1.0 / np.sum(self.w ** 2)
        self.cc = (4 + self.mueff / n) / (n + 4 + 2 * self.mueff / n)
        self.cs = (self.mueff + 2) / (n + self.mueff + 5)
        self.c1 = 2 / ((n + 1.3) ** 2 + self.mueff)
        self.cmu = min(1 - self.c1, 2 * (self.mueff - 2 + 1 / self.mueff) / ((n + 2) ** 2 + self.mueff))
        self.damps = 1 + 2 * max(0.0, np.sqrt((self.mueff - 1) / (n + 1)) - 1) + self.cs
        self.chi_n = np.sqrt(n) * (1 - 1 / (4 * n) + 1 / (21 * n ** 2))
        self.mean = np.array(x0, np.float64)
        self.sigma = float(sigma)
        self.C = np.eye(n)
        self.B, self.D = np.eye(n), np.ones(n)
        self.pc, self.ps = np.zeros(n), np.zeros(n)
        self.gen = 0
        self.rng = rng

    def ask(self) -> np.ndarray:
        z = self.rng.standard_normal((self.lam, self.n))
        return self.mean + self.sigma * (z * self.D) @ self.B.T

    def tell(self, X: np.ndarray, f: np.ndarray) -> None:
        order = np.argsort(f, kind="stable")
        y = (X[order[:self.mu]] - self.mean) / self.sigma
        ymean = self.w @ y
        self.mean = self.mean + self.sigma * ymean
        inv_sqrt = self.B @ np.diag(1 / self.D) @ self.B.T
        self.ps = (1 - self.cs) * self.ps + np.sqrt(self.cs * (2 - self.cs) * self.mueff) * inv_sqrt @ ymean
        self.gen += 1
        hsig = (np.linalg.norm(self.ps) / np.sqrt(1 - (1 - self.cs) ** (2 * self.gen)) / self.chi_n
                < 1.4 + 2 / (self.n + 1))
        self.pc = (1 - self.cc) * self.pc + hsig * np.sqrt(self.cc * (2 - self.cc) * self.mueff) * ymean
        self.C = ((1 - self.c1 - self.cmu) * self.C
                  + self.c1 * (np.outer(self.pc, self.pc) + (1 - hsig) * self.cc * (2 - self.cc) * self.C)
                  + self.cmu * (y.T * self.w) @ y)
        self.sigma *= np.exp((self.cs / self.damps) * (np.linalg.norm(self.ps) / self.chi_n - 1))
        d2, self.B = np.linalg.eigh((self.C + self.C.T) / 2)
        self.D = np.sqrt(np.maximum(d2, 1e-20))


#: Limbs whose length silhouettes see better than the split between their two segments.
SPLITS = (("thigh", "shank"), ("upper_arm", "forearm"))


# -- the joint fit --------------------------------------------------------------------------------
class FramePoses(NamedTuple):
    """One frame of the fit: its number, scorer and the poses found so far (best first)."""

    frame: int
    measure: ShapeMeasure
    particles: np.ndarray  # (M, D)
    weights: np.ndarray  # (M,)


class ShapeFitResult(NamedTuple):
    shape: BodyShape
    frames: list[FramePoses]  # the poses with the fitted shape
    evaluations: int
    seconds: float
    doc: dict  # for run.json and shape.json (see docs/formats.md)


def _measure_params(values: np.ndarray) -> np.ndarray:
    """(..., P) -> (..., G): each group's own measure (its first parameter; the pelvis: B)."""
    return group_factors(values) * stature(values)[..., None]


def log_factors(values: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """(..., G) group log-factors that :func:`ipf_jax.body.proportions.build` maps ``reference``
    onto ``values`` with (exact for values that build made)."""
    return np.log(_measure_params(values) / _measure_params(reference))


class _Objective:
    """The fit's score of candidate bodies over the frames, its prior, and the pose search, with
    the likelihood evaluations they spend (see :func:`fit_shape`)."""

    def __init__(self, frames, reference: BodyShape, U, limits, height_m, settings):
        self.frames, self.U, self.limits, self.height_m, self.s = frames, U, limits, height_m, settings
        self.ref = np.asarray(reference.values, np.float64)
        self.evaluations = 0
        self.bounds = None if settings.foot_bounds is None else {"foot": tuple(settings.foot_bounds)}
        lo, hi = group_bounds(self.bounds)
        self.half = np.log(hi / lo) / 2  # each group's half-width in log units: the prior's scale
        self.centre = np.log([PRIOR_FACTORS.get(n, 1.0) for n in GROUP_NAMES])
        self.pairs = [(GROUP_NAMES.index(a), GROUP_NAMES.index(b)) for a, b in SPLITS]
        self.start = 1.0  # the starting score: the prior's unit

    def body(self, theta: np.ndarray) -> np.ndarray:
        return build(self.ref, theta, self.height_m, bounds=self.bounds)

    def penalty(self, vals: np.ndarray) -> np.ndarray:
        """(L, P) bodies -> (L,) prior penalty in score units."""
        lf = np.log(group_factors(np.atleast_2d(vals)))
        p = self.s.prior * np.sum(((lf - self.centre) / self.half) ** 2, -1)
        for a, b in self.pairs:
            p = p + self.s.split_prior * ((lf[:, a] - lf[:, b]) / self.half[a]) ** 2
        return abs(self.start) * p

    def transfer(self, values: np.ndarray, poses: list[np.ndarray],
                 base: np.ndarray) -> tuple[list[np.ndarray], list[np.ndarray] | None]:
        """Each frame's (M, D) poses, fitted with the body ``base`` (P,), carried over to each of
        the (L, P) bodies: on the floor, the limb angles moved so that the knees, ankles, feet,
        elbows and wrists stay where they were (:func:`ipf_jax.geometry.retarget.retarget`;
        ``retarget_iterations = 0`` keeps the angles). Returns per frame (L * M, D), body-major,
        and with ``carry_angles`` the same poses with their angles kept (else None)."""
        L = len(values)
        qq = np.concatenate([np.repeat(q[None], L, 0).reshape(L * len(q), NUM_DOF) for q in poses])
        vv = np.concatenate([np.repeat(values, len(q), 0) for q in poses])
        placed = place_on_floor_many(qq, vv, self.U)
        splits = np.cumsum([L * len(q) for q in poses])[:-1]
        kept = np.split(self.limits.clip(placed), splits) if self.s.carry_angles else None
        if self.s.retarget_iterations > 0:
            targets = []
            for q in poses:
                b = np.broadcast_to(base, (len(q), len(base)))
                targets.append(np.tile(limb_points(place_on_floor_many(q, b, self.U), b, self.U), (L, 1, 1)))
            placed = retarget(placed, vv, np.concatenate(targets), self.U, self.limits.clip,
                              iterations=self.s.retarget_iterations)
            placed = place_on_floor_many(placed, vv, self.U)
        placed = self.limits.clip(placed)
        return np.split(placed, splits), kept

    def score(self, values: np.ndarray, poses: list[np.ndarray],
              base: np.ndarray) -> tuple[np.ndarray, list[np.ndarray]]:
        """(L, P) bodies -> (L,) mean over frames of each body's best pose (the frames' poses,
        fitted with ``base``, carried over: :meth:`transfer`, each the better of its two
        carry-overs with ``carry_angles``); the carried poses."""
        total = np.zeros(len(values))
        placed_all = []
        L = len(values)
        carried, kept = self.transfer(values, poses, base)
        for k, (fr, placed) in enumerate(zip(self.frames, carried)):
            n = len(placed)
            bodies = np.repeat(values, n // L, 0)
            if kept is not None:  # both carry-overs in one call; per pose the better one
                placed, bodies = np.concatenate([placed, kept[k]]), np.concatenate([bodies, bodies])
            w = fr.measure(placed, bodies)
            self.evaluations += len(placed)
            if kept is not None:
                w_kept = np.where(np.isnan(w[n:]), -np.inf, w[n:])
                better = w_kept > np.where(np.isnan(w[:n]), -np.inf, w[:n])
                placed = np.where(better[:, None], placed[n:], placed[:n])
                w = np.fmax(w[:n], w[n:])
            w = w.reshape(L, -1)
            total += np.where(np.isnan(w), 0.0, w).max(1)
            placed_all.append(placed.reshape(L, -1, NUM_DOF))
        return total / len(self.frames), placed_all

    def refine_poses(self, values: np.ndarray, current: list[FramePoses]) -> list[FramePoses]:
        shape = BodyShape(values, float(stature(values)))
        out = []
        for fr in current:
            measure = _as_body_measure(fr.measure)
            # weighed again with this body: the weights a pose carries are from the body it was
            # found with, and the compass search takes a step when it beats its start's weight
            w0 = measure(fr.particles, shape)
            q, w, n = pattern_search(fr.particles, w0, measure, shape, self.limits,
                                     keep=self.s.pose_keep, sweeps=self.s.pose_sweeps, first_step=0.25)
            self.evaluations += len(w0) + n
            idx = top_distinct(q, w, self.s.pose_keep)
            out.append(fr._replace(particles=q[idx], weights=w[idx]))
        return out

    def starting_point(self) -> tuple[np.ndarray, np.ndarray, list[FramePoses]]:
        """theta, body and kept poses to start from: the reference with the prior's groups (shod
        ankles); the scorers' window buckets grown once with the largest body the bounds allow."""
        theta = np.zeros(NUM_GROUPS)
        for n, f in PRIOR_FACTORS.items():
            k = GROUP_NAMES.index(n)
            theta[k] = np.log(f) - np.log(group_factors(self.ref)[k])
        values = self.body(theta)
        big = self.body(np.full(NUM_GROUPS, 0.5))[None]
        for fr in self.frames:
            fr.measure(self.limits.clip(place_on_floor_many(fr.particles[:1], big, self.U)), big)
        current = [fr._replace(particles=fr.particles[idx], weights=fr.weights[idx])
                   for fr in self.frames for idx in [top_distinct(fr.particles, fr.weights, self.s.pose_keep)]]
        return log_factors(values, self.ref), values, current


def _search(obj: "_Objective", theta, values, current, rng):
    """One alternating pose / shape search (:func:`fit_shape`'s rounds) from ``theta``: the best
    theta, body, poses and score (prior included), and the score after each round."""
    s = obj.s
    history = []
    best_score = -np.inf
    for r in range(s.rounds):
        current = obj.refine_poses(values, current)
        poses = [fr.particles for fr in current]
        best_score = float(obj.score(values[None], poses, values)[0][0] - obj.penalty(values)[0])
        cma = CMAES(theta, s.sigma * 0.7 ** r, s.population, rng)
        for _ in range(s.generations):
            vals = obj.body(cma.ask())
            cand = log_factors(vals, obj.ref)  # repaired into the bounds (and onto the height)
            f, placed = obj.score(vals, poses, values)  # the poses fit `values`
            f = f - obj.penalty(vals)
            cma.tell(cand, -f)
            i = int(np.argmax(f))
            if f[i] > best_score:
                best_score, theta, values = float(f[i]), cand[i], vals[i]
                # the kept poses move with the body (floor contact)
                current = [fr._replace(particles=p[i]) for fr, p in zip(current, placed)]
                poses = [fr.particles for fr in current]
        history.append(round(best_score, 5))
    return theta, values, current, best_score, history


def fit_shape(frames: list[FramePoses], reference: BodyShape, U: np.ndarray, limits: Limits, *,
              height_m: float | None = None, settings: ShapeFitSettings = ShapeFitSettings(),
              seed: int = 0) -> ShapeFitResult:
    """Fit the body's group factors and the frames' poses together (module doc).

    frames : K >= 1 frames with their scorers and starting poses (M_k, D).
    reference : the shape theta = 0 stands for.  height_m : standing height to hold, or None.
    Returns the fitted shape (``height_m`` = its standing height), the frames' refined poses,
    the likelihood evaluations and seconds spent, and a record for run.json.
    """
    require(len(frames) >= 1, "the shape fit needs at least one frame")
    t0 = time.perf_counter()
    s = settings
    rng = np.random.default_rng(seed)
    obj = _Objective(frames, reference, U, limits, height_m, settings)
    theta, values, current = obj.starting_point()
    obj.start = float(obj.score(values[None], [fr.particles for fr in current], values)[0][0])
    history = [round(obj.start, 5)]
    found = [_search(obj, theta, values, current, rng if k == 0 else np.random.default_rng((seed, k)))
             for k in range(s.searches)]
    _, values, current, _, hist = max(found, key=lambda f: f[3])
    if len(found) > 1:  # the searches' bodies averaged (log factors); the best one's poses carried
        base = values
        values = obj.body(np.mean([f[0] for f in found], 0))
        _, placed = obj.score(values[None], [fr.particles for fr in current], base)
        current = [fr._replace(particles=p[0]) for fr, p in zip(current, placed)]
    history += hist
    current = obj.refine_poses(values, current)
    history.append(round(float(obj.score(values[None], [fr.particles for fr in current], values)[0][0]), 5))
    seconds = time.perf_counter() - t0
    doc = {"frames": [int(fr.frame) for fr in frames], "evaluations": int(obj.evaluations),
           "seconds": round(seconds, 3), "height_m_given": height_m,
           "reference_height_m": round(float(stature(obj.ref)), 4),
           "group_factors": {n: round(float(f), 4) for n, f in zip(GROUP_NAMES, group_factors(values))},
           "score_history": history, "settings": settings._asdict(),
           # each frame's best pose with the fitted body (benchmarks/fit_frames.py reads them)
           "frame_poses": [{"frame": int(fr.frame), "weight": _finite(fr.weights[0]),
                            "pose": np.round(fr.particles[0], 6).tolist()} for fr in current]}
    return ShapeFitResult(BodyShape(values, float(stature(values))), current, int(obj.evaluations),
                          seconds, doc)


def _finite(x) -> float | None:
    """A weight for JSON (None when not a number)."""
    return round(float(x), 6) if np.isfinite(x) else None


def spread_frames(frames: list[int], k: int) -> list[int]:
    """``k`` frames spread evenly over ``frames`` (the first and last included when k >= 2)."""
    if k <= 1 or len(frames) <= 1:
        return list(frames[:1])
    idx = np.unique(np.round(np.linspace(0, len(frames) - 1, min(k, len(frames)))).astype(int))
    return [frames[i] for i in idx]


def fit_scorer(scene, shape: BodyShape) -> Scorer:
    """A scorer of its own for the calibration: shape candidates up to the bounds need larger
    windows than the tracking does, and window buckets only grow (see :class:`Scorer`)."""
    s = scene.scorer
    return Scorer(scene.cameras, shape, scene.U, kernel=s.kernel, chunk=s.chunk, threads=s.threads)


# -- pass 1: at the start of a run ------------------------------------------------------------------
class Scene(NamedTuple):
    """What the calibration needs from a tracking run (the tracker builds it).

    observe : frame -> (Observation, masks at scoring resolution).  frames : the run's frames.
    cameras : scoring cameras.  U : (3, 3) up rotation.  limits : DOF ranges.  scorer : the
    run's :class:`Scorer`.  key : frame, salt -> JAX key.  heading : frame -> the direction of
    travel there (rad) or None (:mod:`ipf_jax.tracking.travel`); None: every heading searched.
    prior : particles (N, D), bodies (N, P) -> (N,) factors every weight of the fit is multiplied
    by (the tracker's priors, :mod:`ipf_jax.tracking.prior`); None: the likelihood alone.
    """

    observe: Callable
    frames: list
    cameras: list
    U: np.ndarray
    limits: Limits
    scorer: Scorer
    key: Callable
    heading: Callable | None = None
    prior: ShapeMeasure | None = None


def calibrate_at_start(scene: Scene, frame: int, particles: np.ndarray, weights: np.ndarray,
                       shape: BodyShape, *, height_m: float | None,
                       settings: ShapeFitSettings = ShapeFitSettings(), seed: int = 0,
                       frame_init: InitSettings = FRAME_INIT):
    """Pass 1: fit the shape on ``settings.frames`` frames spread over the recording.

    ``frame``, ``particles``, ``weights``, ``shape``: the first frame's initialisation;
    ``frame_init``: the search that initialises the other frames (shape held).
    Returns (particles, weights, shape, evaluations, doc) for the first frame; ``doc`` records
    the fit (frames, evaluations, seconds including the other frames' initialisations).
    """
    t0 = time.perf_counter()
    evaluations = 0
    scorer = fit_scorer(scene, shape)
    fits = [FramePoses(frame, shape_measure(scorer, scene.observe(frame)[0], scene.prior), particles, weights)]
    skipped = []
    for f in spread_frames(list(scene.frames), settings.frames):
        if f == frame:
            continue
        obs, small = scene.observe(f)
        active = [i for i in range(len(small)) if obs.active[i]]
        if not active:
            skipped.append(int(f))
            continue
        fn = shape_measure(scorer, obs, scene.prior)
        try:
            res = initialise(scene.key(f, 3), [small[i] for i in active], [scene.cameras[i] for i in active],
                             scene.U, scene.limits, shape, _as_body_measure(fn), fixed_shape=shape,
                             settings=frame_init, heading=scene.heading(f) if scene.heading else None)
        except IPFError:  # no silhouette of a person on that frame: use the others
            skipped.append(int(f))
            continue
        evaluations += res.evaluations
        fits.append(FramePoses(f, fn, res.particles, res.weights))
    init_seconds = time.perf_counter() - t0
    # the fit first grows the windows to the largest body (then they stay): its compass steps'
    # 4-127 poses get small compiled calls from here on
    scorer.set_small_chunks(SMALL_CHUNKS)
    result = fit_shape(fits, shape, scene.U, scene.limits, height_m=height_m,
                       settings=for_views(settings, len(scene.cameras)), seed=seed)
    first = result.frames[0]
    doc = dict(result.doc, passes=1, frame_init_evaluations=int(evaluations),
               frame_init_seconds=round(init_seconds, 3), skipped_frames=skipped,
               evaluations=int(evaluations + result.evaluations),
               seconds=round(time.perf_counter() - t0, 3))
    return first.particles, first.weights, result.shape, int(evaluations + result.evaluations), doc


# -- pass 2: refit on a finished track, track again -------------------------------------------------
def refit_from_track(scene: Scene, tracked: dict[int, np.ndarray], shape: BodyShape, *,
                     height_m: float | None, settings: ShapeFitSettings = ShapeFitSettings(),
                     seed: int = 0) -> ShapeFitResult:
    """Fit the shape on ``settings.refit_frames`` frames of a finished track.

    tracked : frame -> (D,) pose of the first pass (tracked frames only).
    """
    frames = spread_frames(sorted(tracked), settings.refit_frames)
    poses = {f: scene.limits.clip(np.asarray(tracked[f], np.float64)[None]) for f in frames}
    res = fit_on_poses(scene, poses, shape, height_m=height_m, settings=settings, seed=seed)
    return res._replace(doc=dict(res.doc, passes=2, evaluations=res.evaluations))


def fit_on_poses(scene: Scene, poses: dict[int, np.ndarray], shape: BodyShape, *,
                 height_m: float | None, settings: ShapeFitSettings = ShapeFitSettings(),
                 seed: int = 0) -> ShapeFitResult:
    """The shape fit (:func:`fit_shape`, :func:`for_views` the scene's cameras) on the frames of
    ``poses`` (frame -> (M, D) poses to start from, within the limits), with ``shape`` as the
    reference body: the refit of pass 2, and ``benchmarks/shape_recovery.py``'s fit from the
    truth's poses."""
    scorer = fit_scorer(scene, shape)
    values = np.asarray(shape.values, np.float32)
    fits = []
    for f, q in poses.items():
        obs, _ = scene.observe(f)
        fn = shape_measure(scorer, obs, scene.prior)
        fits.append(FramePoses(f, fn, q, fn(q, np.broadcast_to(values, (len(q), len(values))))))
    scorer.set_small_chunks(SMALL_CHUNKS)  # as in calibrate_at_start
    return fit_shape(fits, shape, scene.U, scene.limits, height_m=height_m,
                     settings=for_views(settings, len(scene.cameras)), seed=seed)


def shape_doc(shape: BodyShape, source: str, fit: dict | None = None) -> dict:
    """The shape-file document (``shape.json``): height, params, where it came from, the fit."""
    doc = {"height_m": round(float(shape.height_m), 5), "source": source,
           "params": {k: round(v, 6) for k, v in shape.to_json()["params"].items()},
           "standing_height_m": round(float(stature(shape.values)), 5),
           "group_factors": {n: round(float(f), 4) for n, f in zip(GROUP_NAMES, group_factors(shape.values))}}
    if fit is not None:
        doc["fit"] = fit
    return doc


def write_shape(path: str | Path, doc: dict) -> None:
    from ..data.runfiles import write_json_atomic

    write_json_atomic(Path(path), doc)


__all__ = [
    "CMAES",
    "FRAME_INIT",
    "GROUPS",
    "FramePoses",
    "Scene",
    "ShapeFitResult",
    "ShapeFitSettings",
    "calibrate_at_start",
    "fit_on_poses",
    "fit_shape",
    "lowest_heights",
    "place_on_floor_many",
    "refit_from_track",
    "shape_doc",
    "shape_measure",
    "spread_frames",
    "write_shape",
]
