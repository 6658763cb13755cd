"""Forward kinematics in JAX: one particle's 31 DOF -> 19 points and 17 capsules (world, metres).

Written for ONE particle; the kinematic tree of :mod:`ipf_jax.body.model` is unrolled at trace time.
The same code also runs on NumPy arrays with leading particle axes (``xp=numpy``): the vectorised
NumPy baseline (:mod:`ipf_jax.reference.scanline`) uses it, while :mod:`ipf_jax.geometry.host` stays
the independent oracle.

:func:`capsule_ends` is the scorer's batched form (particle axis last, JAX): each joint's sine and
cosine computed once for the whole batch, each body frame's axes composed once from its parent's,
and each distinct capsule end placed once (the end of a thigh is the start of its shank). Which of
these values XLA keeps in memory and which it recomputes inside a fused loop is its fusion's choice:
the CPU pipeline removes ``optimization_barrier`` before fusing (``OptimizationBarrierExpander``).
The barriers below still stop the algebraic simplifier from rewriting across them before that,
and the compiled arithmetic depends on them to the last bit (docs/benchmarks.md, nineteenth
session), so they stay.
"""
from __future__ import annotations

from typing import NamedTuple

import jax
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
from .trig import sincos


FRAMES_BY_NAME = {f.name: f for f in FRAMES}


class Pose3D(NamedTuple):
    """points : (J, 3);  seg_a, seg_b : (S, 3) capsule sphere centres;  seg_r : (S, 2) radii."""

    points: jnp.ndarray
    seg_a: jnp.ndarray
    seg_b: jnp.ndarray
    seg_r: jnp.ndarray


def _plus(a, x, b, y):
    """a x + b y for vectors as arrays (..., 3) or as tuples of coordinate arrays."""
    if isinstance(x, tuple):
        return tuple(a * xi + b * yi for xi, yi in zip(x, y))
    return a * x + b * y


def _minus(a, x, b, y):
    """a x - b y (see :func:`_plus`)."""
    if isinstance(x, tuple):
        return tuple(a * xi - b * yi for xi, yi in zip(x, y))
    return a * x - b * y


def _turn(cols, axis: str, c, s):
    """Columns of ``R @ R_axis(angle)`` from the angle's cosine ``c`` and sine ``s``: an elementary
    rotation only mixes two columns.

    Working on columns with elementwise arithmetic (no 3x3 dot products) keeps the unrolled tree a
    handful of fusible loops: it compiles in seconds and vectorises over particles.
    """
    c0, c1, c2 = cols
    if axis == "x":
        return c0, _plus(c, c1, s, c2), _minus(c, c2, s, c1)
    if axis == "y":
        return _minus(c, c0, s, c2), c1, _plus(s, c0, c, c2)
    return _plus(c, c0, s, c1), _minus(c, c1, s, c0), c2


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
            p = tuple(pi + ci * v for pi, ci in zip(p, col)) if isinstance(p, tuple) else p + col * v
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
            angle = sign * q[..., i:i + 1]  # (..., 1): broadcasts over xyz
            cols = _turn(cols, axis, *sincos(xp, angle))
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


def frame_axes(q_t: np.ndarray, shape_values, up: np.ndarray, names, xp=np) -> dict:
    """Only the body frames ``names`` and their ancestors, particle axis last: ``{name: (cols,
    origin)}``, each frame's three axes and its origin as tuples of coordinate arrays (B,).

    q_t : (D, B) particles.  shape_values : (P,) one body, or (P, B) a body per particle.
    The arithmetic of :func:`forward_kinematics` on the frames it needs (the tracking priors read
    two or three points of every particle; placing all 19 would cost ten times more).
    """
    need = set()
    for name in names:
        while name is not None and name not in need:
            need.add(name)
            name = FRAMES_BY_NAME[name].parent
    world = {}
    for f in FRAMES:
        if f.name not in need:
            continue
        if f.parent is None:
            cols = tuple(tuple(up[r, c] for r in range(3)) for c in range(3))
            origin = (q_t[0], q_t[1], q_t[2])
        else:
            pcols, porigin = world[f.parent]
            cols, origin = pcols, _apply(pcols, porigin, f.origin, shape_values)
        for axis, sign, dof in f.rotation:
            angle = sign * q_t[DOF_INDEX[dof]]
            cols = _turn(cols, axis, *sincos(xp, angle))
        world[f.name] = (cols, origin)
    return world


def place(world: dict, frame: str, coords, shape_values) -> tuple:
    """A position given in ``frame`` (shape-parameter expressions) in the world, as a tuple of
    coordinate arrays, from :func:`frame_axes`' result."""
    cols, origin = world[frame]
    return _apply(cols, origin, coords, shape_values)


def _end_key(frame: str, coords) -> tuple:
    """A capsule end as (frame, position), a frame's origin written in its parent's frame."""
    f = FRAMES_BY_NAME[frame]
    if f.parent is not None and all(c == 0 for c in coords):
        return _end_key(f.parent, f.origin)
    return frame, tuple(coords)

#: the distinct capsule end centres, (frame, position) each, in order of first use
CAPSULE_ENDS = tuple(dict.fromkeys(_end_key(s.frame, e) for s in SEGMENTS for e in (s.a, s.b)))
#: (S, 2) index into :data:`CAPSULE_ENDS` of each segment's ends a and b
SEGMENT_ENDS = np.array([[CAPSULE_ENDS.index(_end_key(s.frame, e)) for e in (s.a, s.b)]
                         for s in SEGMENTS])
#: (S, 2) index into the shape values of each segment's end radii
SEGMENT_RADII = np.array([[SHAPE_INDEX[s.r_a], SHAPE_INDEX[s.r_b]] for s in SEGMENTS])


#: smallest padded host call of a particle-last kernel (:func:`padded_particles`); calls are padded
#: to powers of two from it, so a run compiles a handful of sizes (filters' calls vary in length)
MIN_BLOCK = 64


def padded_particles(particles: np.ndarray, shape_values: np.ndarray) -> tuple:
    """Host-side padding for the particle-last kernels (:func:`capsule_ends` and its callers),
    which take ``q.T`` (each DOF a row) on the device.

    (N, D) particles -> ``(q, sv, n)``: ``q`` (B, D) float32, B the next power of two >= N (at
    least :data:`MIN_BLOCK`), the padding rows copies of the first particle (a real pose: no 0/0
    on the padding); ``sv`` the shape values in float32, (P,) as given or, for a body per particle
    (N, P), (B, P) padded the same way; ``n`` = N, the entries to keep of a result. N must be > 0.

    The rows are copied as they are: the transposed float32 copy the kernels used to get from the
    host cost 0.7 ms of a tracked IPF frame with one camera (the lean prior's call), this copy and
    the transpose on the device 0.2 (docs/benchmarks.md); the kernels see the same numbers."""
    n = len(particles)
    block = max(MIN_BLOCK, 1 << (n - 1).bit_length())
    q = np.empty((block, np.shape(particles)[1]), np.float32)
    q[:n] = particles
    q[n:] = q[:1]
    sv = np.asarray(shape_values, np.float32)
    if sv.ndim == 2:
        sv = np.concatenate([sv, np.repeat(sv[:1], block - n, axis=0)])
    return q, sv, n


def rows_of(q: jnp.ndarray, shape_values: jnp.ndarray) -> tuple:
    """Inside a kernel: :func:`padded_particles`' ``q`` and ``sv`` with the particle axis last,
    (D, B) and (P,) or (P, B)."""
    return q.T, (shape_values.T if shape_values.ndim == 2 else shape_values)


def capsule_ends(q_t: jnp.ndarray, shape_values: jnp.ndarray, up: jnp.ndarray) -> jnp.ndarray:
    """Batched FK, particle axis last (JAX): (D, B) -> (3, K, B) world centres of the K distinct
    capsule ends (:data:`CAPSULE_ENDS`; :data:`SEGMENT_ENDS` maps segments onto them); particles
    (D, *lead, B) -> (3, *lead, K, B).

    shape_values : (P,) one body for all, or (P, *lead, B) a body per particle.  up : (3, 3).
    The operations on each number are those of :func:`forward_kinematics` (compiled into other
    loops, so a result can differ from it in the last bit).
    """
    angles = jnp.stack([sign * q_t[DOF_INDEX[dof]] for f in FRAMES for _, sign, dof in f.rotation])
    cos, sin = jax.lax.optimization_barrier(sincos(jnp, angles))  # once per joint in the traced program
    world = {}
    k = 0
    for f in FRAMES:
        if f.parent is None:
            cols = tuple(tuple(up[r, c] for r in range(3)) for c in range(3))  # columns, by coordinate
            origin = (q_t[0], q_t[1], q_t[2])
        else:
            pcols, porigin = world[f.parent]
            cols, origin = pcols, _apply(pcols, porigin, f.origin, shape_values)
        for axis, _, _ in f.rotation:
            cols = _turn(cols, axis, cos[k], sin[k])
            k += 1
        world[f.name] = jax.lax.optimization_barrier((cols, origin))  # each frame's axes traced once
    ends = [jnp.stack(_apply(*world[frame], coords, shape_values)) for frame, coords in CAPSULE_ENDS]
    return jnp.stack(ends, axis=-2)  # every end moves with the root: (3, *lead, B) each
