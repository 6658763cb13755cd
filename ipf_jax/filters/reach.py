"""The arms' reach search: an arm searched over its whole range from the frame's best pose.

The factored filter's arm groups search a few degrees around the kept particles, so an arm that
the track got wrong (an arm hanging straight where the person holds the forearm forward, left
by a noisy first frame) stays wrong: every small move from the hanging arm towards the bent one
takes pixels off the body and scores worse, and the right arm sits in a narrow basin of its own
(docs/fipf.md, "The arms' reach search"). This stage looks for that basin directly, with the rest
of the body held at the frame's best pose, for one arm a frame, drawn with the frame's key
(:func:`pick`: an arm the track got wrong stays wrong for many frames, so it is found within a
few, at half the cost of both).

The basin is narrow where the whole arm moves and wide where only the forearm does: on the
renders the weight falls by about a seventh 2.5 deg from the true shoulder flexion or abduction,
by as much 10 deg from its rotation and by a tenth 20 deg from its elbow flexion (docs/fipf.md).
So the search goes from the upper arm to the forearm, each on a grid spaced for its own basin,
then refines:

1. **the upper arm**: shoulder flexion x abduction on :data:`UPPER_FLEXION_DEG` x
   :data:`UPPER_ABDUCTION_DEG`, each with the forearm in the two :data:`FOREARM_STARTS_DEG`
   (rotation, elbow flexion: a forearm hanging and one held forward);
2. **the forearm**: the :data:`FOREARM_KEEP` best distinct upper arms, each with every shoulder
   rotation x elbow flexion of :data:`FOREARM_ROTATION_DEG` x :data:`FOREARM_ELBOW_DEG`;
3. **compass sweeps** on the four DOFs from the best pose of each upper arm's family (its grid
   point and its forearms: the current arm's basin, which the grids sample too, cannot take
   both), one per step of :data:`STEPS_DEG` (``+- step`` on each DOF around each start; the last
   sweep's combined move of the improving ones weighed in the same call, Hooke-Jeeves, so that a
   sweep is one measure call).

Every grid value is clipped to the limits. The poses that beat the frame's best weight by more
than :data:`MARGIN` join the frame's pool, so a clearly better arm becomes the frame's estimate and
a kept particle of the next frame; the others change nothing.
"""
from __future__ import annotations

import itertools
from typing import Callable

import numpy as np

from ..body.model import DOF_INDEX
from .compass import improving_direction
from .selection import top_distinct

#: The DOFs of each arm: shoulder flexion, abduction, rotation, elbow flexion.
ARMS: tuple[tuple[int, ...], ...] = tuple(
    tuple(DOF_INDEX[f"{side}_{d}"] for d in ("shoulder_flexion", "shoulder_abduction",
                                              "shoulder_rotation", "elbow_flexion"))
    for side in ("left", "right"))
#: The upper arm's grid (degrees): finer where arms are in everyday movement (hanging, swinging,
#: held forward), coarser above.
UPPER_FLEXION_DEG: tuple[float, ...] = (-30.0, -15.0, 0.0, 15.0, 30.0, 50.0, 75.0, 100.0)
UPPER_ABDUCTION_DEG: tuple[float, ...] = (0.0, 12.0, 24.0, 40.0)
#: The forearm (shoulder rotation, elbow flexion; degrees) of each upper-arm grid point.
FOREARM_STARTS_DEG: tuple[tuple[float, float], ...] = ((0.0, 35.0), (0.0, 110.0))
#: Distinct upper arms whose forearm is searched, and the forearm's grid (degrees).
FOREARM_KEEP = 2
FOREARM_ROTATION_DEG: tuple[float, ...] = (-40.0, -20.0, 0.0, 20.0, 40.0)
FOREARM_ELBOW_DEG: tuple[float, ...] = (10.0, 40.0, 70.0, 100.0, 130.0)
#: The compass sweeps' steps (degrees), one sweep each.
STEPS_DEG: tuple[float, ...] = (10.0, 6.0, 4.0, 2.0, 1.0)
#: The tracker searches the arms' reach by default only with this many cameras or more
#: (``--reach`` / ``--no-reach`` decide otherwise). Measured with the first form of the search
#: (docs/fipf.md): with 4 cameras the sit-to-stand runs 36.3 -> 30.0 mm, the walks unchanged; with
#: 2 the two-camera walks 45.3 -> 39.9 (6 runs); with 1 the one-camera walks 128.6 -> 132.5 at
#: seed 0, better in 2 of 8 runs only. This form: sit-to-stand 30.0 -> 27.0, the walks 25.3 ->
#: 25.1, two cameras 39.9 -> 40.7 (6 runs).
MIN_VIEWS = 2
#: What a reach pose must gain over the frame's best weight to be kept (a fraction of it):
#: smaller gains are as likely an arm fitted to a shadow as the true one (docs/fipf.md).
MARGIN = 0.03


def gainers(weights: np.ndarray, best_weight: float) -> np.ndarray:
    """(N,) bool: the reach poses that beat ``best_weight`` by more than :data:`MARGIN`."""
    return np.asarray(weights) > best_weight * (1.0 + MARGIN)


def pick(z: float) -> int:
    """The arm searched this frame from one standard normal draw of the frame's key."""
    return int(z > 0.0)


def grid() -> np.ndarray:
    """(G, 4) the upper arm's grid: arm DOF values (radians) of stage 1."""
    upper = itertools.product(UPPER_FLEXION_DEG, UPPER_ABDUCTION_DEG)
    return np.deg2rad(np.array([(f, a, r, e) for f, a in upper for r, e in FOREARM_STARTS_DEG]))


def forearm_grid() -> np.ndarray:
    """(F, 2) the forearm's grid: shoulder rotation and elbow flexion (radians) of stage 2."""
    return np.deg2rad(np.array(list(itertools.product(FOREARM_ROTATION_DEG, FOREARM_ELBOW_DEG))))


def calls() -> tuple[int, ...]:
    """Particles of each measure call: the upper arm's grid, the forearm's, one call per sweep
    (both families' moves)."""
    return (len(grid()), FOREARM_KEEP * len(forearm_grid())) + (FOREARM_KEEP * 9,) * len(STEPS_DEG)


def cost() -> int:
    """Evaluations per frame (the sum of :func:`calls`)."""
    return sum(calls())


def _moves(centres: np.ndarray, dofs: tuple[int, ...], step: float) -> np.ndarray:
    """(K, 9, D): each of the (K, D) ``centres``, then ``+- step`` on each of the arm's four
    ``dofs``."""
    out = np.repeat(centres[:, None], 9, axis=1)
    out[:, 1::2, list(dofs)] += np.eye(4) * step
    out[:, 2::2, list(dofs)] -= np.eye(4) * step
    return out


def _weighed(cand: np.ndarray, measure, clip, seen: list) -> tuple[np.ndarray, np.ndarray]:
    """(N, D) ``cand`` clipped and weighed, the pair also appended to ``seen``."""
    cand = clip(cand)
    seen.append((cand, np.asarray(measure(cand), float)))
    return seen[-1]


def search(best: np.ndarray, arm: int, measure: Callable[[np.ndarray], np.ndarray],
           clip: Callable[[np.ndarray], np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Arm ``arm``'s (of :data:`ARMS`) reach search from the (D,) ``best`` pose: (N, D) particles
    weighed, (N,) their weights (N = :func:`cost`, in the calls of :func:`calls`). ``measure``
    (K, D) -> (K,); ``clip`` into the limits (the stages: module doc)."""
    best = np.asarray(best, np.float64)
    dofs = list(ARMS[arm])
    seen: list = []
    arms, forearms = grid(), forearm_grid()
    upper = np.repeat(best[None], len(arms), axis=0)
    upper[:, dofs] = arms
    upper, w = _weighed(upper, measure, clip, seen)
    top = top_distinct(upper, w, FOREARM_KEEP)  # the best distinct upper arms
    k, n_fore = len(top), len(forearms)
    fore = np.repeat(upper[top], n_fore, axis=0)
    fore[:, dofs[2:]] = np.tile(forearms, (k, 1))
    fore, fw = _weighed(fore, measure, clip, seen)
    # each upper arm's family: its grid point and its forearms; the sweeps start from each's best
    fam = np.concatenate([upper[top][:, None], fore.reshape(k, n_fore, -1)], axis=1)
    fam_w = np.concatenate([w[top][:, None], fw.reshape(k, n_fore)], axis=1)
    rows = np.arange(k)
    base, base_w = fam[rows, fam_w.argmax(1)], fam_w.max(1)
    combined = base  # the last sweep's combined moves (the first sweep weighs the bases again)
    for step in np.deg2rad(STEPS_DEG):
        moves = _moves(base, ARMS[arm], step)
        moves[:, 0] = combined
        flat, mw = _weighed(moves.reshape(k * 9, -1), measure, clip, seen)
        per, at = mw.reshape(k, 9), flat.reshape(k, 9, -1)
        gain = per[:, 1:].reshape(k, 4, 2) - base_w[:, None, None]
        combined = base.copy()
        combined[:, dofs] += improving_direction(gain[..., 0], gain[..., 1]) * step
        i = per.argmax(1)
        better = per[rows, i] > base_w
        base = np.where(better[:, None], at[rows, i], base)
        base_w = np.where(better, per[rows, i], base_w)
    return np.concatenate([p for p, _ in seen]), np.concatenate([x for _, x in seen])


__all__ = ["ARMS", "FOREARM_ELBOW_DEG", "FOREARM_KEEP", "FOREARM_ROTATION_DEG", "FOREARM_STARTS_DEG",
           "MARGIN", "MIN_VIEWS", "STEPS_DEG", "UPPER_ABDUCTION_DEG", "UPPER_FLEXION_DEG", "calls", "cost",
           "forearm_grid", "gainers", "grid", "pick", "search"]
