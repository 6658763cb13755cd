"""Interval Particle Filtering (Saboune & Charpillet).

Per frame, with no motion model:

1. *Selection*: the M heaviest distinct particles of the previous frame (host, stable order).
2. *Prediction*: each kept particle's 'interesting' sub-vector L is replaced by a deterministic
   grid of I = P^|L| neighbours (P points per DOF across the interval), and the rest R gets
   independent white Gaussian noise for each of the N = M x I new particles; clip to the limits.
3. *Measure*: weigh all N; the heaviest particle is the frame's estimate.

The interval's full width is ``2 * max_speed / fps``, or given directly per frame
(``interval_width_deg``). The paper used 100 deg/s (+-5 deg per 50 ms, 10 deg at 20 Hz). That lags
a walking knee: in the real marker walk of ``mocap_walk_render`` the knee angle changes by up to 20
deg per 50 ms (90th percentile 15 deg), the hip by up to 9 deg, and with 100 deg/s the knees and
ankles of the tracked walk trailed the truth (knee error 67 mm vs 35 mm at 300 deg/s, all else
equal). The default is therefore 300 deg/s (+-15 deg at 20 Hz); ``--max-speed 100`` restores the
paper's setting.
"""
from __future__ import annotations

import itertools
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from ..body.limits import Limits
from ..body.model import DEFAULT_INTERESTING, DOF_INDEX, NUM_DOF
from ..errors import require
from ..lowered import Program
from .base import (
    Filter,
    FilterState,
    default_noise_rates,
    rate_std,
    standard_normal,
    summarise,
)
from .selection import top_distinct


class IPFSettings(NamedTuple):
    top_m: int = 81
    points_per_dof: int = 3
    interesting: tuple[str, ...] = DEFAULT_INTERESTING
    max_speed_deg_s: float = 300.0  # see the module docstring for why not the paper's 100
    interval_width_deg: float | None = None  # full width per frame; overrides max_speed
    noise_scale: float = 1.0  # multiplies the default per-DOF noise rates

    def grid_size(self) -> int:
        return self.points_per_dof ** len(self.interesting)


def validate(settings: IPFSettings) -> None:
    require(settings.top_m >= 1, f"top M must be >= 1 (got {settings.top_m})")
    require(settings.points_per_dof >= 1, f"points per DOF must be >= 1 (got {settings.points_per_dof})")
    require(len(settings.interesting) >= 1, "the interesting sub-vector L needs at least one DOF")
    unknown = [d for d in settings.interesting if d not in DOF_INDEX]
    require(not unknown, f"unknown DOF in L: {', '.join(unknown)}")
    require(len(set(settings.interesting)) == len(settings.interesting), "L lists a DOF twice")
    require(0 < settings.max_speed_deg_s < np.inf,
            f"max angular speed must be > 0 and finite (got {settings.max_speed_deg_s})")
    if settings.interval_width_deg is not None:
        require(0 < settings.interval_width_deg < np.inf,
                f"interval width must be > 0 degrees and finite (got {settings.interval_width_deg})")
    require(0 <= settings.noise_scale < np.inf,
            f"noise scale must be >= 0 and finite (got {settings.noise_scale})")


def interval_grid(settings: IPFSettings, fps: float) -> np.ndarray:
    """(I, |L|) offsets (radians) of the deterministic neighbour grid, centre included."""
    width = (np.deg2rad(settings.interval_width_deg) if settings.interval_width_deg is not None
             else 2.0 * np.deg2rad(settings.max_speed_deg_s) / fps)
    p = settings.points_per_dof
    axis = np.zeros(1) if p == 1 else np.linspace(-width / 2, width / 2, p)
    return np.array(list(itertools.product(axis, repeat=len(settings.interesting))))


def _runs(columns: np.ndarray) -> list[tuple[slice, slice]]:
    """Sorted ``columns`` as runs of consecutive ones: (slice of the columns, slice of their
    positions in ``columns``)."""
    runs, start = [], 0
    for k in range(1, len(columns) + 1):
        if k == len(columns) or columns[k] != columns[k - 1] + 1:
            runs.append((slice(int(columns[start]), int(columns[k - 1]) + 1), slice(start, k)))
            start = k
    return runs


def _in_columns(z: jax.Array, columns: tuple[int, ...], width: int) -> jax.Array:
    """(N, K) draws -> (N, ``width``) float32, draw column k in column ``columns[k]`` (ascending),
    zeros elsewhere: the step scales them into its particles in one contiguous pass. Runs of
    columns concatenated (a scatter took 0.4 ms of the device for 6561 x 27, this 0.1)."""
    zero = jnp.zeros((z.shape[0], 1), z.dtype)
    pieces, at = [], 0
    for dst, src in _runs(np.array(columns)):
        pieces += [zero] * (dst.start - at) + [z[:, src]]
        at = dst.stop
    return jnp.concatenate(pieces + [zero] * (width - at), axis=1)


#: :func:`_in_columns` as a program of its own (the normals stay :func:`standard_normal`'s program:
#: placed inside it, their bits would be the compiler's to fuse)
in_columns = Program(_in_columns, ("columns", "width"))


def build(settings: IPFSettings, limits: Limits, fps: float) -> Filter:
    """The IPF kernel for fixed settings (closure, like blackjax's build_kernel)."""
    validate(settings)
    grid = interval_grid(settings, fps)  # (I, |L|)
    L = np.array([DOF_INDEX[d] for d in settings.interesting])
    R = np.setdiff1d(np.arange(NUM_DOF), L)
    std = np.zeros(NUM_DOF)  # per column: the noise's std on R, 0 on L (the grid's columns)
    std[R] = rate_std(default_noise_rates()[R], fps) * settings.noise_scale
    m, i = settings.top_m, len(grid)
    n = m * i
    # the grid's columns written run by run (basic slices): fancy-index writes of N x D cost ~5x
    # more; the offsets first, then the kept particles added in one pass (0.6 ms a frame against 1.2)
    runs_l = _runs(L)

    def init(particles, weights):
        return FilterState(np.asarray(particles, float), np.asarray(weights, float))

    def draws(rng_key: jax.Array) -> jax.Array:
        """(N, D) float32: the standard normals of R's columns (N, |R|) in those columns."""
        return in_columns(standard_normal(rng_key, (n, len(R))), columns=tuple(map(int, R)),
                          width=NUM_DOF)

    def step(rng_key: jax.Array, state: FilterState, measure, drawn: jax.Array | None = None,
             shift: np.ndarray | None = None):
        # drawn ahead by the caller, or dispatched first: drawn while the host selects
        z = drawn if drawn is not None and drawn.shape == (n, NUM_DOF) else draws(rng_key)
        kept = state.particles[top_distinct(state.particles, state.weights, m, shift)]  # (M, D)
        if shift is not None:  # moved as the whole set would be: the same sums
            kept += shift
        # each particle's offset from its kept particle (the float32 draws widened exactly inside
        # the product; 0 on L), then the grid on L, then the sum
        new = np.multiply(np.asarray(z), std, dtype=np.float64)
        per_kept = new.reshape(m, i, NUM_DOF)  # particle j*I + k = kept j, neighbour k
        for dst, src in runs_l:
            per_kept[:, :, dst] = grid[None, :, src]
        per_kept += kept[:, None, :]  # one contiguous pass (the sums are those of kept + offset)
        new = limits.clip(new, copy=False)
        weights = np.asarray(measure(new), float)
        return FilterState(new, weights), summarise(new, weights, n)

    params = {"top_m": m, "grid_points": i, "points_per_dof": settings.points_per_dof,
              "interesting": list(settings.interesting),
              "interval_width_deg": float(np.rad2deg(grid[:, 0].max() - grid[:, 0].min())),
              "particles": n, "noise_scale": settings.noise_scale}
    return Filter("ipf", init, step, n, params, (n,), draws)
