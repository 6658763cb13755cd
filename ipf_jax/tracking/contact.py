"""Floor contact: the body can neither sink into the floor nor float above it.

Like the per-DOF ranges, a limit on configurations rather than a motion model: after the filter's
prediction, every particle whose lowest capsule surface point lies outside
``[floor_min, floor_max]`` metres above the floor (``up . X = 0``) is moved along world up into the
range. Walking, standing, sitting and lying always keep something on the floor; running and
jumping need a wider range.

The idea is that it matters most with one camera: a body moved along a viewing ray changes size in
the image only slightly, but it leaves the floor. **It is off by default** because it did not pay on
real motion rendered into masks (``mocap_walk_render``, 32 frames, default IPF, MPJPE of the 12 limb
joints; measured 2026-11-26): 4 cameras 47.0 mm with ``(-0.03, 0.10)`` vs 44.0 mm without; 1 camera
125.4 vs 117.9 mm, at ~1.2-1.4x the seconds per frame (one more forward kinematics per particle).
There the 1-camera error comes from the subject's scale (height found 1.85 m) and leg swaps, not
from floating; the constraint also trusts that the calibration's floor is ``up . X = 0``.
``--floor-range LO,HI`` turns it on.
"""
from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from ..body.limits import Limits
from ..body.shape import BodyShape
from ..geometry.kinematics import forward_kinematics

DEFAULT_RANGE = (-0.03, 0.10)  # metres: 3 cm into soft ground/shoes, 10 cm of flight


def _lowest(q, shape_values, up):
    pose = forward_kinematics(q, shape_values, up)
    u = up[:, 2]
    return jnp.minimum(jnp.min(pose.seg_a @ u - pose.seg_r[:, 0]), jnp.min(pose.seg_b @ u - pose.seg_r[:, 1]))


_lowest_batch = jax.jit(jax.vmap(_lowest, in_axes=(0, None, None)))


def lowest_heights(particles: np.ndarray, shape: BodyShape, U: np.ndarray, chunk: int = 4096) -> np.ndarray:
    """(N,) height above the floor of each particle's lowest capsule surface point (metres)."""
    sv, up = np.asarray(shape.values, np.float32), np.asarray(U, np.float32)
    out = np.empty(len(particles))
    for start in range(0, len(particles), chunk):
        block = particles[start:start + chunk].astype(np.float32)
        n = len(block)
        if n < chunk and len(particles) > chunk:  # keep one compiled shape
            block = np.concatenate([block, np.repeat(block[:1], chunk - n, axis=0)])
        out[start:start + n] = np.asarray(_lowest_batch(block, sv, up))[:n]
    return out


class FloorContact(NamedTuple):
    """Per-DOF limits plus floor contact; a drop-in for :class:`Limits` in the filters
    (they call ``.clip``)."""

    limits: Limits
    shape: BodyShape
    U: np.ndarray
    floor_min: float = DEFAULT_RANGE[0]
    floor_max: float = DEFAULT_RANGE[1]

    @property
    def lower(self):
        return self.limits.lower

    @property
    def upper(self):
        return self.limits.upper

    @property
    def name(self):
        return self.limits.name

    def clip(self, x: np.ndarray, *, copy: bool = True) -> np.ndarray:
        x = self.limits.clip(x, copy=copy)
        h = lowest_heights(x, self.shape, self.U)
        lift = np.clip(h, self.floor_min, self.floor_max) - h  # 0 inside the range
        x[:, :3] += lift[:, None] * self.U[:, 2]
        return x
