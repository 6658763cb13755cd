"""The posture group: the pelvis moved forward, up and pitched with both feet held in place.

The factored filter (:mod:`.fipf`) searches one group of DOFs at a time with the others held.
Rising from a chair moves the pelvis forward and up, tips it back and straightens the hips and
knees together, with the feet planted; every move of one group alone (the root, the pelvis
pitch, one leg) from a crouch towards standing lifts or slides a foot and scores worse than
the crouch. So the track could stay crouched behind a person who had stood up: on
``sub4_sts_clean_4cam`` for 12 frames, hips 13-19 cm behind, on tiptoe, weight 3.4-3.9 where
the true pose scores 4.4-8.1 (docs/fipf.md, "The posture group").

This group searches those DOFs together: a grid over the pelvis's forward and upward translation
(along the body's heading in the floor plane, and along up) and its pitch, and for each grid
point the legs' angles (hips, knees, ankles) that bring both ankles, heels and toes back to where
the parent particle had them (:func:`ipf_jax.geometry.retarget.hold` on
:data:`~ipf_jax.geometry.retarget.FEET`: :data:`ITERATIONS` Levenberg-Marquardt steps, never
ending further from the feet than the move alone left them). It needs the body (its shape values
and up rotation), so the filter has it only when it is built with one (the tracker's always is;
by default the tracker turns the group on with :data:`MIN_VIEWS` cameras or more).
"""
from __future__ import annotations

import itertools
from typing import NamedTuple

import numpy as np

from ..body.model import DOF_INDEX
from ..geometry.kinematics import frame_axes
from ..geometry.retarget import FEET, hold, limb_points

#: Maximum speeds of the posture grid's three directions in everyday movement: the pelvis forward
#: and up (m/s) and its pitch (deg/s), as :data:`ipf_jax.filters.fipf.MAX_SPEEDS` has them for the
#: root's translation and the pelvis pitch (rising from a chair: Schenkman et al. 1990).
SPEEDS = (0.4, 0.4, 100.0)
#: Levenberg-Marquardt steps that bring the feet back (after 4, within 0.1 mm for most of a
#: crouch's grid moves and within a few millimetres for all that stay in reach:
#: tests/test_posture.py).
ITERATIONS = 4
NAME = "posture"
#: The tracker searches the posture group by default only with this many cameras or more
#: (``--posture`` turns it on with fewer). With one or two cameras it changed nothing beyond the
#: seeds' spread over the 20 walk runs of the one- and two-camera renders at seeds 0 and 1
#: (docs/fipf.md) and would cost about a third of a one-camera frame, whose measure step is short;
#: the feet it holds are where a single view cannot place them well either.
MIN_VIEWS = 3
_PITCH = DOF_INDEX["root_pitch"]


class Body(NamedTuple):
    """What the posture group needs of the subject: ``values`` (P,) shape values, ``U`` (3, 3)
    the up rotation (world up is ``U[:, 2]``)."""

    values: np.ndarray
    U: np.ndarray


def grid(points_per_dof: int, fps: float, speed_scale: float = 1.0) -> np.ndarray:
    """(P^3, 3) round-0 offsets: forward (m), up (m), pitch (rad); the centre row is all zeros
    for odd P (row (P^3 - 1) // 2)."""
    half = np.array([SPEEDS[0] / fps, SPEEDS[1] / fps, np.deg2rad(SPEEDS[2] / fps)]) * speed_scale
    axis = np.zeros(1) if points_per_dof == 1 else np.linspace(-1.0, 1.0, points_per_dof)
    return np.array(list(itertools.product(axis, repeat=3))) * half


def heading(poses: np.ndarray, body: Body) -> np.ndarray:
    """(M, 3) unit vectors: each pose's pelvis forward axis, projected onto the floor plane."""
    world = frame_axes(np.asarray(poses, np.float64).T, np.asarray(body.values, np.float64),
                       np.asarray(body.U, np.float64), ["pelvis"])
    fwd = np.stack(np.broadcast_arrays(*world["pelvis"][0][0]), -1)  # (M, 3) its x axis
    up = np.asarray(body.U, np.float64)[:, 2]
    fwd = fwd - (fwd @ up)[:, None] * up
    return fwd / np.maximum(np.linalg.norm(fwd, axis=1, keepdims=True), 1e-12)


def children(kept: np.ndarray, offsets: np.ndarray, body: Body, clip) -> np.ndarray:
    """(M x G, D) children of the (M, D) ``kept`` particles (child j*G + k = kept j moved by
    ``offsets[k]``), each with its legs moved so that its feet stay where kept j has them; the
    zero offset's child is kept j itself. ``clip`` keeps them in the DOF ranges."""
    kept = np.asarray(kept, np.float64)
    m, g = len(kept), len(offsets)
    values = np.asarray(body.values, np.float64)
    U = np.asarray(body.U, np.float64)
    up = U[:, 2]
    off = np.tile(offsets, (m, 1))  # (M G, 3)
    new = np.repeat(kept, g, axis=0)
    new[:, :3] += off[:, :1] * np.repeat(heading(kept, body), g, axis=0) + off[:, 1:2] * up
    new[:, _PITCH] += off[:, 2]
    moved = np.any(off != 0, axis=1)
    if not moved.any():
        return new
    feet = limb_points(kept, np.broadcast_to(values, (m, len(values))), U, which=FEET)  # (M, 6, 3)
    targets = np.repeat(feet, g, axis=0)[moved]
    bodies = np.broadcast_to(values, (int(moved.sum()), len(values)))
    new[moved] = hold(clip(new[moved]), bodies, targets, U, clip, which=FEET, iterations=ITERATIONS)
    return new


__all__ = ["Body", "ITERATIONS", "MIN_VIEWS", "NAME", "SPEEDS", "children", "grid", "heading"]
