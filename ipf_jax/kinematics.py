"""Forward kinematics in JAX: one particle's 31 DOF -> 19 points and 17 capsules (world, metres).

Written for ONE particle; the kinematic tree of :mod:`ipf_jax.body.model` is unrolled at trace time.
Batch with ``jax.vmap`` at a factory boundary (see :mod:`ipf_jax.likelihood`).
"""
from __future__ import annotations

from typing import NamedTuple

import jax.numpy as jnp

from .body.model import DOF_INDEX, FRAMES, NUM_POINTS, POINTS, SEGMENTS, SHAPE_INDEX, parse_coord


class Pose3D(NamedTuple):
    """points : (J, 3);  seg_a, seg_b : (S, 3) capsule sphere centres;  seg_r : (S, 2) radii."""

    points: jnp.ndarray
    seg_a: jnp.ndarray
    seg_b: jnp.ndarray
    seg_r: jnp.ndarray


def _rot(axis: str, angle):
    c, s = jnp.cos(angle), jnp.sin(angle)
    o, z = jnp.ones_like(c), jnp.zeros_like(c)
    if axis == "x":
        rows = ((o, z, z), (z, c, -s), (z, s, c))
    elif axis == "y":
        rows = ((c, z, s), (z, o, z), (-s, z, c))
    else:
        rows = ((c, -s, z), (s, c, z), (z, z, o))
    return jnp.stack([jnp.stack(r, -1) for r in rows], -2)


def _pos(coords, shape_values):
    out = []
    for coord in coords:
        acc = jnp.zeros((), shape_values.dtype)
        for sign, idx in parse_coord(coord):
            acc = acc + sign * shape_values[idx]
        out.append(acc)
    return jnp.stack(out)


def forward_kinematics(q: jnp.ndarray, shape_values: jnp.ndarray, up: jnp.ndarray) -> Pose3D:
    """One particle.

    q : (D,) DOF vector (radians / metres).  shape_values : (P,) BodyShape.values.
    up : (3, 3) rotation U mapping the body's canonical frame (z up) into the world.
    """
    world = {}
    for f in FRAMES:
        R = None
        for axis, sign, dof in f.rotation:
            r = _rot(axis, sign * q[DOF_INDEX[dof]])
            R = r if R is None else R @ r
        if f.parent is None:
            Rw = up @ R
            tw = q[jnp.array([0, 1, 2])]
        else:
            Rp, tp = world[f.parent]
            Rw = Rp @ R
            tw = tp + Rp @ _pos(f.origin, shape_values)
        world[f.name] = (Rw, tw)

    def place(frame, coords):
        Rw, tw = world[frame]
        return tw + Rw @ _pos(coords, shape_values)

    points = jnp.stack([place(p.frame, p.position) for p in POINTS])  # (J, 3)
    seg_a = jnp.stack([place(s.frame, s.a) for s in SEGMENTS])  # (S, 3)
    seg_b = jnp.stack([place(s.frame, s.b) for s in SEGMENTS])  # (S, 3)
    seg_r = jnp.stack([jnp.stack([shape_values[SHAPE_INDEX[s.r_a]], shape_values[SHAPE_INDEX[s.r_b]]])
                       for s in SEGMENTS])  # (S, 2)
    assert points.shape == (NUM_POINTS, 3)
    return Pose3D(points, seg_a, seg_b, seg_r)
