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
Measured again on 2026-12-04 with one camera (8 visible one-camera walks x 4 seeds, lean prior on,
``(-0.03, 0.03)``): 155.8 -> 151.9 mm on the mean, within the seeds' spread (docs/single_camera.md).
``--floor-range LO,HI`` turns it on.
"""
from __future__ import annotations

from typing import NamedTuple

import jax.numpy as jnp
import numpy as np

from ..body.limits import Limits
from ..body.shape import BodyShape
from ..geometry.kinematics import (
    SEGMENT_ENDS,
    SEGMENT_RADII,
    capsule_ends,
    padded_particles,
    rows_of,
)
from ..lowered import Program

DEFAULT_RANGE = (-0.03, 0.10)  # metres: 3 cm into soft ground/shoes, 10 cm of flight


@Program  # a jit whose lowering is kept on disk (ipf_jax.lowered)
def _lowest_jit(q, shape_values, up):
    """(B, D) padded particles (:func:`padded_particles`) -> (B,) lowest capsule surface point
    over the floor, float32: the scorer's particle-last forward kinematics of the distinct capsule
    ends, then each segment's lower end less its radius."""
    q_t, shape_values = rows_of(q, shape_values)
    ends = capsule_ends(q_t, shape_values, up)  # (3, K, B)
    height = up[0, 2] * ends[0] + up[1, 2] * ends[1] + up[2, 2] * ends[2]  # (K, B)
    r = shape_values[SEGMENT_RADII]  # (S, 2)
    low = jnp.minimum(height[SEGMENT_ENDS[:, 0]] - r[:, :1], height[SEGMENT_ENDS[:, 1]] - r[:, 1:])
    return jnp.min(low, axis=0)


def lowest_heights(particles: np.ndarray, shape: BodyShape, U: np.ndarray) -> np.ndarray:
    """(N,) height above the floor of each particle's lowest capsule surface point (metres).

    One compiled float32 call, particle axis last, padded by
    :func:`~ipf_jax.geometry.kinematics.padded_particles`; ``tracking.shape_fit.lowest_heights``
    is the float64 NumPy version the tests compare."""
    if len(particles) == 0:
        return np.empty(0)
    q, sv, n = padded_particles(particles, shape.values)
    out = _lowest_jit(q, sv, np.asarray(U, np.float32))
    return np.asarray(out, np.float64)[:n]


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
