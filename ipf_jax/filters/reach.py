"""The arms' reach search: an arm searched over its whole range from the frame's best pose.

The factored filter's arm groups search a few degrees around the kept particles, so an arm that
the track got wrong (an arm hanging straight where the person holds the forearm forward, left
by a noisy first frame) stays wrong: every small move from the hanging arm towards the bent one
takes pixels off the body and scores worse, and the right arm sits in a narrow basin of its own
(docs/fipf.md, "The arms' reach search"). This stage looks for that basin directly, with the rest
of the body held at the frame's best pose, for one arm a frame, drawn with the frame's key
(:func:`pick`: an arm the track got wrong stays wrong for many frames, so it is found within a
few, at half the cost of both):

1. a coarse grid over the arm's four DOFs (:data:`GRID_DEG`: shoulder flexion x abduction x
   rotation x elbow flexion, 72 points, each clipped to the limits);
2. the :data:`KEEP` best distinct grid points refined by :data:`SWEEPS` compass sweeps on those
   four DOFs (Hooke-Jeeves: ``+- step`` on each and the combined move of the improving ones,
   weighed as the next sweep's centre so that a sweep is one measure call; the step
   :data:`STEP_DEG` halving per sweep).

The poses that beat the frame's best weight by more than :data:`MARGIN` join the frame's pool,
so a clearly better arm becomes the frame's estimate and a kept particle of the next frame; the
others change nothing.
"""
from __future__ import annotations

import itertools
from typing import Callable

import numpy as np

from ..body.model import DOF_INDEX
from .compass import improving_direction
from .selection import top_distinct

#: The DOFs of each arm, in the grid's order.
ARMS: tuple[tuple[int, ...], ...] = tuple(
    tuple(DOF_INDEX[f"{side}_{d}"] for d in ("shoulder_flexion", "shoulder_abduction",
                                              "shoulder_rotation", "elbow_flexion"))
    for side in ("left", "right"))
#: The coarse grid, degrees per DOF of :data:`ARMS` (every arm pose of everyday movement lies
#: within about 25 deg of one of its points, in each DOF).
GRID_DEG: tuple[tuple[float, ...], ...] = ((-30.0, 15.0, 60.0, 105.0), (0.0, 40.0),
                                           (-45.0, 0.0, 45.0), (0.0, 50.0, 100.0))
#: Distinct grid points of each arm refined by the compass sweeps.
KEEP = 3
#: Compass sweeps, and the first sweep's step (halved after each).
SWEEPS = 4
STEP_DEG = 20.0
#: The tracker searches the arms' reach by default only with this many cameras or more
#: (``--reach`` / ``--no-reach`` decide otherwise). Measured (docs/fipf.md): with 4 cameras the
#: sit-to-stand runs 36.3 -> 30.0 mm, the walks unchanged; with 2 the two-camera walks 45.3 ->
#: 39.9 (6 runs); with 1 the one-camera walks 128.6 -> 125.5 at seed 0, better in 4 of 8 runs only.
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
    """(G, 4) the coarse grid's arm DOF values (radians)."""
    return np.deg2rad(np.array(list(itertools.product(*GRID_DEG))))


def cost() -> int:
    """Evaluations per frame: the arm's grid, then per sweep ``KEEP x 9``."""
    return len(grid()) + SWEEPS * KEEP * 9


def calls() -> tuple[int, ...]:
    """Particles of each measure call: the grid, then one call per sweep."""
    return (len(grid()),) + (KEEP * 9,) * SWEEPS


def _moves(centres: np.ndarray, dofs: tuple[int, ...], step: float) -> np.ndarray:
    """(K x 9, D): each centre, then ``+- step`` on each of the arm's four ``dofs``."""
    offsets = np.zeros((9, 4))
    offsets[1::2] = np.eye(4) * step
    offsets[2::2] = -np.eye(4) * step
    out = np.repeat(centres, 9, axis=0)
    out[:, list(dofs)] += np.tile(offsets, (len(centres), 1))
    return out


def search(best: np.ndarray, arm: int, measure: Callable[[np.ndarray], np.ndarray],
           clip: Callable[[np.ndarray], np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Arm ``arm``'s (of :data:`ARMS`) reach search from the (D,) ``best`` pose: (N, D) particles
    weighed, (N,) their weights (N = :func:`cost`). ``measure`` (K, D) -> (K,); ``clip`` into the
    limits.

    A sweep weighs, for each start, a centre and its eight moves in one call: the centre is the
    last sweep's combined move (every DOF moved in its improving direction, Hooke-Jeeves), weighed
    one sweep late so that a sweep is one call; each start keeps the best it has weighed."""
    best = np.asarray(best, np.float64)
    g = grid()
    cand = np.repeat(best[None], len(g), axis=0)
    cand[:, ARMS[arm]] = g
    cand = clip(cand)
    w = np.asarray(measure(cand), float)
    seen_p, seen_w = [cand], [w]
    idx = top_distinct(cand, w, KEEP)
    base, base_w = cand[idx], w[idx]  # (S, D) starts, their weights
    dofs = list(ARMS[arm])
    centre = base.copy()
    step = np.deg2rad(STEP_DEG)
    for _ in range(SWEEPS):
        moves = clip(_moves(centre, ARMS[arm], step))
        mw = np.asarray(measure(moves), float)
        seen_p.append(moves)
        seen_w.append(mw)
        per, at = mw.reshape(len(base), 9), moves.reshape(len(base), 9, -1)
        top = per.argmax(axis=1)
        better = per[np.arange(len(base)), top] > base_w
        base[better] = at[better, top[better]]
        base_w[better] = per[better, top[better]]
        gain = per[:, 1:].reshape(len(base), 4, 2) - per[:, :1, None]  # (S, 4, +-)
        centre = base.copy()  # the next sweep's centre: the combined move from this one's
        centre[:, dofs] = at[:, 0, dofs] + improving_direction(gain[..., 0], gain[..., 1]) * step
        step *= 0.5
    return np.concatenate(seen_p), np.concatenate(seen_w)


__all__ = ["ARMS", "GRID_DEG", "KEEP", "MARGIN", "MIN_VIEWS", "STEP_DEG", "SWEEPS", "calls", "cost",
           "gainers", "grid", "pick", "search"]
