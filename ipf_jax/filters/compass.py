"""Compass search: Hooke-Jeeves' exploratory move from the best distinct configurations.

Each sweep takes the ``keep`` heaviest distinct particles, tries ``+- step`` on every DOF one at a
time, then the combination of every DOF's improving step; the steps halve from one sweep to the
next. Deterministic, and good at the last centimetres and degrees, where random moves in 31
dimensions rarely improve all at once. Used by the automatic initialisation and the shape fit
(``ipf_jax.tracking``) and, as its last stage, by the factored filter (``polish``,
docs/fipf.md).

:data:`SEARCH_STD` is the per-DOF scale of a local search around a whole-body guess: what the
initialisation's random refinement draws with, and what the compass steps are fractions of.
"""
from __future__ import annotations

from typing import Callable

import numpy as np

from ..body.model import DOF_NAMES, NUM_DOF
from .selection import top_distinct

#: Per-DOF scale of a local search: root translation x, y, z (m), root yaw, pitch, roll, then
#: every joint angle (rad); rotations about long axes (and ankle inversion) are weakly observable
#: and searched gently (see filters.base).
SEARCH_STD = np.concatenate([[0.08, 0.08, 0.04], np.deg2rad([25.0, 8.0, 8.0]),
                             np.full(NUM_DOF - 6, np.deg2rad(15.0))])
_GENTLE = [i for i, n in enumerate(DOF_NAMES) if n.endswith(("_rotation", "ankle_inversion"))]
SEARCH_STD[_GENTLE] = np.deg2rad(5.0)


def sweep_cost(keep: int, n_dof: int = NUM_DOF) -> int:
    """Evaluations of one sweep: ``keep`` x (2 moves per DOF + the combined move)."""
    return keep * (2 * n_dof + 1)


def improving_direction(up: np.ndarray, down: np.ndarray) -> np.ndarray:
    """Each DOF's step direction in Hooke-Jeeves' combined move, from the weight gained by ``+
    step`` (``up``) and by ``- step`` (``down``): +1, -1, or 0 when neither improves."""
    return np.where((up > 0) & (up >= down), 1.0, np.where(down > 0, -1.0, 0.0))


def compass_search(particles: np.ndarray, weights: np.ndarray, measure: Callable[[np.ndarray], np.ndarray],
                   clip: Callable[[np.ndarray], np.ndarray], step: np.ndarray, *, keep: int,
                   sweeps: int) -> tuple[np.ndarray, np.ndarray, int]:
    """``sweeps`` compass sweeps from the ``keep`` heaviest distinct ``particles`` (N, D).

    measure : (K, D) -> (K,) weights;  clip : (K, D) -> (K, D) into the DOF limits;
    step : (D,) the first sweep's step per DOF (halved after each sweep).
    Returns the last sweep's pool (its kept particles, their moves and combined moves) with their
    weights, and the evaluations spent (``sweeps x`` :func:`sweep_cost`).
    """
    n_dof = particles.shape[1]
    evaluations = 0
    for _ in range(sweeps):
        idx = top_distinct(particles, weights, keep)
        kept, kept_w = particles[idx], weights[idx]
        moves = np.concatenate([np.diag(step), -np.diag(step)])  # (2D, D)
        cand = clip((kept[:, None, :] + moves[None]).reshape(-1, n_dof))
        w = measure(cand).reshape(len(kept), 2 * n_dof)
        gain = w - kept_w[:, None]
        direction = improving_direction(gain[:, :n_dof], gain[:, n_dof:])
        combined = clip(kept + direction * step)
        wc = measure(combined)
        evaluations += cand.shape[0] + len(combined)
        particles = np.concatenate([kept, cand, combined])
        weights = np.concatenate([kept_w, w.ravel(), wc])
        step = step * 0.5
    return particles, weights, evaluations
