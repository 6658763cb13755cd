"""Forward kinematics in JAX: one particle's 31 DOF -> 19 points and 17 capsules (world, metres).

Written for ONE particle; the kinematic tree of :mod:`ipf_jax.body.model` is unrolled at trace time.
Batch with ``jax.vmap`` at a factory boundary (see :mod:`ipf_jax.likelihood.scorer`). The same code also
runs on NumPy arrays with leading particle axes (``xp=numpy``): the vectorised NumPy baseline
(:mod:`ipf_jax.reference.scanline`) uses it, while :mod:`ipf_jax.geometry.host` stays the
independent oracle.
"""
from __future__ import annotations

from typing import NamedTuple

import jax.numpy as jnp
import numpy as np

from ..body.model import (
    DOF_INDEX,
    FRAMES,
    NUM_POINTS,
    POINTS,
    SEGMENTS,
    SHAPE_INDEX,
    parse_coord,
)


class Pose3D(NamedTuple):
    """points : (J, 3);  seg_a, seg_b : (S, 3) capsule sphere centres;  seg_r : (S, 2) radii."""

    points: jnp.ndarray
    seg_a: jnp.ndarray
    seg_b: jnp.ndarray
    seg_r: jnp.ndarray


def _turn(cols, axis: str, angle, xp):
    """Columns of ``R @ R_axis(angle)``: an elementary rotation only mixes two columns.

    Working on columns with elementwise arithmetic (no 3x3 dot products) keeps the unrolled tree a
    handful of fusible loops: it compiles in seconds and vectorises over particles.
    """
    c, s = xp.cos(angle), xp.sin(angle)
    c0, c1, c2 = cols
    if axis == "x":
        return c0, c * c1 + s * c2, c * c2 - s * c1
    if axis == "y":
        return c * c0 - s * c2, c1, s * c0 + c * c2
    return c * c0 + s * c1, c * c1 - s * c0, c2


def _coords(coords, shape_values):
    out = []
    for coord in coords:
        terms = parse_coord(coord)
        acc = None
        for sign, idx in terms:
            t = shape_values[idx] if sign > 0 else -shape_values[idx]
            acc = t if acc is None else acc + t
        out.append(acc)  # None stands for 0
    return out


def _apply(cols, origin, coords, shape_values):
    """origin + R @ v for a position given as shape-parameter expressions."""
    p = origin
    for col, v in zip(cols, _coords(coords, shape_values)):
        if v is not None:
            p = p + col * v
    return p


def forward_kinematics(q: jnp.ndarray, shape_values: jnp.ndarray, up: jnp.ndarray,
                       xp=jnp) -> Pose3D:
    """One particle (or, with NumPy, any leading particle axes ``...``).

    q : (..., D) DOF vector (radians / metres).  shape_values : (P,) BodyShape.values.
    up : (3, 3) rotation U mapping the body's canonical frame (z up) into the world.
    Returns a :class:`Pose3D` with leading axes ``...``.
    """
    world = {}
    for f in FRAMES:
        if f.parent is None:
            cols = (up[:, 0], up[:, 1], up[:, 2])
            origin = q[..., :3]
        else:
            pcols, porigin = world[f.parent]
            cols, origin = pcols, _apply(pcols, porigin, f.origin, shape_values)
        for axis, sign, dof in f.rotation:
            i = DOF_INDEX[dof]
            cols = _turn(cols, axis, sign * q[..., i:i + 1], xp)  # (..., 1): broadcasts over xyz
        world[f.name] = (cols, origin)

    def place(frame, coords):
        cols, origin = world[frame]
        return xp.broadcast_to(_apply(cols, origin, coords, shape_values), q.shape[:-1] + (3,))

    # one stacked output (..., J + 2S, 3): separate stacks make XLA's fusion passes much slower
    placed = xp.stack([place(p.frame, p.position) for p in POINTS]
                      + [place(s.frame, s.a) for s in SEGMENTS]
                      + [place(s.frame, s.b) for s in SEGMENTS], axis=-2)
    j, n = len(POINTS), len(SEGMENTS)
    points = placed[..., :j, :]  # (..., J, 3)
    seg_a, seg_b = placed[..., j:j + n, :], placed[..., j + n:, :]  # (..., S, 3)
    r_idx = np.array([[SHAPE_INDEX[s.r_a], SHAPE_INDEX[s.r_b]] for s in SEGMENTS])
    seg_r = shape_values[r_idx]  # (S, 2)
    assert points.shape[-2:] == (NUM_POINTS, 3)
    return Pose3D(points, seg_a, seg_b, seg_r)
