"""Weak priors the silhouettes cannot supply, multiplied into every weight the tracker computes (its
filter, the initialisation and recovery searches).

**The pelvis is level** (``--pelvis-prior SIGMA``; off by default). The pelvis's roll (its tilt to
the side, ``root_roll``) is nearly unobservable in silhouettes: a pelvis rolled by 15 deg with the
trunk bent back by 15 deg (``trunk_lateral``) and the hips abducted to match casts almost the
silhouettes of a level pelvis, so the likelihood is flat along that combination and the filter
drifts on it (docs/fipf.md). The factor is ``exp(-roll^2 / (2 sigma^2))``; the shape fit's own
scores do not carry it. Measured with sigma 20 deg on the visible 4-camera walks (seeds 0/1/2):
the tracked pelvis's tilt off the truth's by 1.2 deg on the run's mean instead of 4.4 (none over 5
deg instead of 11 of 30 runs). The joint positions were not better (10 walks 27.5 -> 27.8 mm) and
sit-to-stand was worse (60.1 -> 66.3 mm), so it is an option for walking trials whose pelvic
obliquity matters, not the default (docs/fipf.md).

**Upright along one camera's line of sight** (``--lean-prior SIGMA``, 10 deg by default, used only
with ONE camera). One view measures a lean towards or away from the camera only through the
silhouette's small changes of size; left free, the tracked body leaned away from the camera by
5-21 deg (trunk) and up to 37 deg (hips over ankles) on the visible one-camera walks, whose truth is
within 4.5 and 8.4 deg. The factor is ``exp(-(trunk^2 + legs^2) / (2 sigma^2))`` of the trunk's
(hips' midpoint -> shoulders' midpoint) and the legs' (ankles' midpoint -> hips' midpoint) lean in
the vertical plane through the camera and the hips (:func:`lean_angles`); a lean across the line
of sight, which the silhouette shows, costs nothing. "Upright" is the joint centres' line, as
the ground truth's is measured: the model's rest pose, whose hip joints sit ``hip_forward`` in
front of the pelvis, reads 4.7 deg back when it faces the camera, so the prior flexes its trunk
that much forward (the rendered walkers' own hips-to-shoulders line is within 4.5 deg of vertical).
The prior is decided per data set (one camera), not per frame: a rig with one camera left active
on some frames gets none; it fades out for a camera steeply above the person (:data:`STEEP_FULL`).
The shape fit's scores carry it too (a body
fitted leaning is a body of the wrong proportions). The measured effect is in
docs/single_camera.md; its cost, on ``sequenceB_2`` with one camera under the profiler, 2.5 % of
an IPF frame and 5 % of a factored-IPF frame (``benchmarks/frame_profile.py``, stage "priors").
"""
from __future__ import annotations

import jax.numpy as jnp
import numpy as np

from ..body.model import DOF_INDEX
from ..geometry.kinematics import frame_axes, padded_particles, place, rows_of
from ..lowered import Program

ROLL = DOF_INDEX["root_roll"]


def level_pelvis(particles: np.ndarray, sigma_deg: float) -> np.ndarray:
    """(N,) prior factors in (0, 1] of (N, D) particles: 1 for a level pelvis; all 1 with
    ``sigma_deg`` 0."""
    roll = np.asarray(particles, float)[:, ROLL]
    if sigma_deg <= 0:
        return np.ones(len(roll))
    return np.exp(-0.5 * (roll / np.deg2rad(sigma_deg)) ** 2)


#: where the lean prior reads the body (frame, position in it): the hips' midpoint, the shoulders'
#: midpoint and the two ankles
_MID_HIP = ("pelvis", ("+hip_forward", 0, "-hip_down"))
_MID_SHOULDER = ("trunk", (0, 0, ("+trunk", "-shoulder_drop")))
_ANKLES = (("left_shank", (0, 0, "-shank")), ("right_shank", (0, 0, "-shank")))


#: the prior fades out for a camera that looks steeply down on the person: full while the
#: camera -> hips direction is at least this horizontal (its horizontal share; 0.5: 60 deg below
#: the horizon), none from :data:`STEEP_OFF` down (above the person the "line of sight" has no
#: horizontal direction to lean along)
STEEP_FULL, STEEP_OFF = 0.5, 0.2


def _leans(q_t, sv, up, centre, xp):
    """(trunk, legs, level) of particles ``q_t`` (D, B), bodies ``sv`` (P,) or (P, B), in the array
    module ``xp`` (NumPy: the reference; jax.numpy: the tracker's compiled kernel): the two lean
    angles and how much of the prior applies, 1 for a camera not steeply above the person (the
    steep fade, :data:`STEEP_FULL`)."""
    world = frame_axes(q_t, sv, up, ("pelvis", "trunk", "left_shank", "right_shank"), xp=xp)
    hip = place(world, *_MID_HIP, sv)
    shoulder = place(world, *_MID_SHOULDER, sv)
    left, right = place(world, *_ANKLES[0], sv), place(world, *_ANKLES[1], sv)
    ankle = tuple(0.5 * (a + b) for a, b in zip(left, right))
    vertical = tuple(up[r, 2] for r in range(3))
    away = [h - centre[r] for r, h in enumerate(hip)]  # horizontal direction camera -> hips
    rise = sum(a * v for a, v in zip(away, vertical))
    away = [a - rise * v for a, v in zip(away, vertical)]
    norm = xp.sqrt(sum(a * a for a in away))
    slant = xp.sqrt(norm * norm + rise * rise)
    level = xp.clip((norm / xp.maximum(slant, 1e-12) - STEEP_OFF) / (STEEP_FULL - STEEP_OFF), 0.0, 1.0)

    def lean(a, b):
        v = [bi - ai for ai, bi in zip(a, b)]
        along = sum(vi * wi for vi, wi in zip(v, away))
        length = xp.sqrt(sum(vi * vi for vi in v)) * norm
        return xp.arcsin(xp.clip(along / xp.maximum(length, 1e-12), -1.0, 1.0))

    return lean(hip, shoulder), lean(ankle, hip), level


def lean_angles(particles: np.ndarray, shape_values: np.ndarray, up: np.ndarray,
                centre: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(N,) angles (radians) by which each particle's trunk (hips' midpoint -> shoulders' midpoint)
    and legs (ankles' midpoint -> hips' midpoint) lean away from a camera at ``centre`` (3,), in the
    vertical plane through the camera and the hips (positive: the top further from the camera).
    NumPy, float64: the reference of the tracker's compiled :func:`upright_to_camera`.

    shape_values : (P,) one body, or (N, P) a body per particle.
    up : (3, 3) the tracker's rotation of the body's canonical frame (z up) into the world.
    """
    return _reference(particles, shape_values, up, centre)[:2]


def _reference(particles, shape_values, up, centre):
    q_t = np.ascontiguousarray(np.asarray(particles, float).T)  # each DOF a contiguous row
    sv = np.asarray(shape_values, float)
    return _leans(q_t, sv.T if sv.ndim == 2 else sv, np.asarray(up, float),
                  np.asarray(centre, float), np)


def upright_reference(particles: np.ndarray, shape_values: np.ndarray, up: np.ndarray,
                      centre: np.ndarray, sigma_deg: float) -> np.ndarray:
    """:func:`upright_to_camera` in NumPy float64 (the reference the tests check it against)."""
    trunk, legs, level = _reference(particles, shape_values, up, centre)
    return np.exp(-0.5 * level * (trunk ** 2 + legs ** 2) / np.deg2rad(sigma_deg) ** 2)


@Program  # a jit whose lowering is kept on disk (ipf_jax.lowered)
def _upright_jit(q, shape_values, up, centre, inv_sigma):
    """q (B, D) padded particles, shape_values (P,) or (B, P) (:func:`padded_particles`). Returns
    the exponent: the host takes its exp in float64 (float32 would underflow to 0 for a small
    sigma)."""
    trunk, legs, level = _leans(*rows_of(q, shape_values), up, centre, jnp)
    return 0.5 * level * ((trunk * inv_sigma) ** 2 + (legs * inv_sigma) ** 2)


def upright_to_camera(particles: np.ndarray, shape_values: np.ndarray, up: np.ndarray,
                      centre: np.ndarray, sigma_deg: float) -> np.ndarray:
    """(N,) prior factors in (0, 1]: ``exp(-(trunk^2 + legs^2) / 2 sigma^2)`` of the lean angles
    along the camera's line of sight (:func:`lean_angles`), faded out for a camera steeply above
    the person (:data:`STEEP_FULL`); all 1 with ``sigma_deg`` 0; 0 for a particle with NaNs.

    One compiled call in float32, padded to a power of two by
    :func:`~ipf_jax.geometry.kinematics.padded_particles`: 0.25 /
    0.9 / 4.0 ms for 64 / 650 / 6561 particles against the NumPy reference's 1.6 / 2.7 / 9.8 on a
    2-core EPYC; tests/test_tracker.py checks it against :func:`lean_angles`."""
    n = len(particles)
    if sigma_deg <= 0 or n == 0:
        return np.ones(n)
    q, sv, n = padded_particles(particles, shape_values)
    out = _upright_jit(q, sv, np.asarray(up, np.float32), np.asarray(centre, np.float32),
                       np.float32(1.0 / np.deg2rad(sigma_deg)))
    factors = np.exp(-np.asarray(out, np.float64)[:n])
    return np.where(np.isfinite(factors), factors, 0.0)  # a particle with NaNs: no weight
