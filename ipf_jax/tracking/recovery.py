"""Recovery of a lost track: around the last good pose first, then over the whole grid.

When the track is lost (:mod:`.loss`, or the relative confidence collapses) the tracker calls
:func:`recover` on the frame:

1. **Local**: the last pose that passed the loss test, and each posture of
   :data:`ipf_jax.geometry.posing.POSTURES_DEG` and the standing one, at floor positions around
   where the silhouettes now put the person and at headings around the last good heading (and
   turned round), each placed on the floor; the best distinct configurations are refined as in
   the initialisation (:func:`ipf_jax.tracking.initialise.refine_modes`, a small budget).
2. **Global**: when the local result still fails the loss test or weighs no more than the
   estimate it would replace (which the tracker would not accept), the full initialisation search
   with the subject's shape (:func:`ipf_jax.tracking.initialise.initialise`, postures included).

The best result found is returned with the evaluations it cost; the tracker accepts it only if it
explains the silhouettes better (a higher weight) than the pose it replaces. The cost is bounded:
one local search (:data:`LOCAL`, ~6000 evaluations) and at most one global search
(:data:`GLOBAL`, ~17000) per attempt, and while lost an attempt every ``--recovery-retry`` frames;
every attempt's evaluations are recorded in ``run.json``.
"""
from __future__ import annotations

from typing import Callable, NamedTuple

import jax
import numpy as np

from ..body.limits import Limits
from ..body.shape import BodyShape
from ..geometry.camera import Camera
from ..geometry.posing import POSTURES_DEG, gait_pose, place_on_floor, posture_pose
from .initialise import InitSettings, Measure, floor_points, initialise, refine_modes

#: the local search's budget: few modes, one refinement round, a short compass search
LOCAL = InitSettings(headings=8, position_steps=1, modes=2, keep=8, refine_rounds=1,
                     refine_particles=128, pattern_keep=4, pattern_sweeps=3, posture_modes=0)
#: the global search's budget: the initialisation's grid (16 headings, 3 x 3 positions, walking
#: configurations and postures) with three modes refined in two rounds (~17000 evaluations,
#: against ~70000 for the first frame's search, which also looks for the height)
GLOBAL = InitSettings(headings=16, position_steps=1, modes=2, keep=16, refine_rounds=2,
                      refine_particles=256, pattern_keep=4, pattern_sweeps=4, posture_modes=1)
#: headings tried around the last good one (degrees); 180 for a person who turned round
LOCAL_TURNS_DEG = (-60.0, -30.0, 0.0, 30.0, 60.0, 180.0)


class Recovery(NamedTuple):
    """One recovery attempt: the best (N, D) particles and (N,) weights found, the stage that
    found them (``local`` or ``global``), and the likelihood evaluations spent."""

    particles: np.ndarray
    weights: np.ndarray
    stage: str
    evaluations: int


def local_grid(last_good: np.ndarray, foot: np.ndarray, shape: BodyShape, U: np.ndarray,
               limits: Limits, step_m: float = 0.15) -> np.ndarray:
    """(G, D) configurations around the last good pose (see module doc): its posture and the
    others x :data:`LOCAL_TURNS_DEG` about its heading x 3 x 3 floor positions around ``foot``."""
    postures = [last_good.copy(), gait_pose(5, 5, 5, 5)] + [posture_pose(*p) for p in POSTURES_DEG.values()]
    offsets = step_m * np.arange(-1, 2)
    out = []
    for k, base in enumerate(postures):
        base = base.copy()
        if k > 0:
            base[3:6] = last_good[3:6]  # the new postures keep the last good orientation
        for turn in np.deg2rad(LOCAL_TURNS_DEG):
            q = base.copy()
            q[:3] = 0.0
            q[3] = (base[3] + turn + np.pi) % (2 * np.pi) - np.pi
            q = place_on_floor(q, shape.values, U)
            for dx in offsets:
                for dy in offsets:
                    qq = q.copy()
                    qq[:3] = q[:3] + foot + dx * U[:, 0] + dy * U[:, 1]
                    out.append(qq)
    return limits.clip(np.array(out))


def recover(rng_key: jax.Array, masks: list[np.ndarray], cameras: list[Camera], U: np.ndarray,
            limits: Limits, shape: BodyShape, measure: Measure, still_lost: Callable[[np.ndarray], bool],
            last_good: np.ndarray | None, *, global_settings: InitSettings,
            beat: float | None = None) -> Recovery:
    """Search one frame for the lost subject (see module doc).

    masks, cameras : the active cameras only.  measure(particles, shape) -> weights.
    still_lost(pose) : whether a (D,) pose fails the loss test.  last_good : (D,) or None
    (then only the global search runs).  beat : the weight the local result must exceed to end
    the search (the estimate's: a lighter result would not be accepted, so the global search
    runs instead; None: passing the loss test is enough).
    """
    evaluations = 0
    best = None
    if last_good is not None:
        foot = floor_points(masks, cameras, U[:, 2], (shape.height_m,))[shape.height_m]
        grid = local_grid(last_good, foot, shape, U, limits)
        w = measure(grid, shape)
        res = refine_modes(jax.random.fold_in(rng_key, 0), grid, w, np.full(len(w), shape.height_m),
                           shape, measure, U, limits, LOCAL, LOCAL.modes, search_height=False,
                           search_proportions=False)
        evaluations += len(grid) + res.evaluations
        best = Recovery(res.particles, res.weights, "local", evaluations)
        top = res.particles[int(np.nanargmax(res.weights))]
        if not still_lost(top) and (beat is None or float(np.nanmax(res.weights)) > beat):
            return best
    res = initialise(jax.random.fold_in(rng_key, 1), masks, cameras, U, limits, shape, measure,
                     fixed_shape=shape, settings=global_settings)
    evaluations += res.evaluations
    if best is None or np.nanmax(res.weights) > np.nanmax(best.weights):
        return Recovery(res.particles, res.weights, "global", evaluations)
    return best._replace(evaluations=evaluations)
