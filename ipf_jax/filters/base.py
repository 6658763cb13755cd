"""What every filter shares: state/info records, noise, and the estimate of a weighted set."""
from __future__ import annotations

import functools
from typing import Callable, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from ..body.limits import Limits
from ..lowered import Program

Measure = Callable[[np.ndarray], np.ndarray]


class FilterState(NamedTuple):
    """particles : (N, D) float64;  weights : (N,) float64 likelihoods of those particles."""

    particles: np.ndarray
    weights: np.ndarray


class FilterInfo(NamedTuple):
    """Per-frame diagnostics.

    best : (D,) heaviest particle (the estimate);  best_weight : its weight;
    mean : (D,) weight-averaged particle;  evaluations : likelihood evaluations this frame.
    """

    best: np.ndarray
    best_weight: float
    mean: np.ndarray
    evaluations: int


class Filter(NamedTuple):
    """A filter = pure functions + its exact per-frame likelihood budget.

    calls : the particle count of each measure call of one frame, in order (their sum is
    ``evaluations_per_frame``); the tracker sizes the scorer's compiled calls from them
    (:func:`ipf_jax.likelihood.scorer.pick_chunk`).

    step : ``step(rng_key, state, measure, drawn=None, shift=None)``; ``shift`` (D,) moves every
    particle of ``state`` first (the tracker's body-origin shift): the step's result is that of
    ``step(rng_key, moved(state, shift), measure)``, a filter that keeps a few particles shifting
    only those (IPF, the factored filter: no N x D copy).

    draws : optional ``draws(rng_key)``: the step's random numbers for ``rng_key``, dispatched
    ahead (device arrays, computed while the host does other work: once a frame is measured the
    tracker asks for the next two frames', while it checks and writes this frame and selects the
    next). A filter that has it
    takes them as ``step(rng_key, state, measure, drawn=...)`` and uses them when their shapes are
    the ones it needs, else draws again: the same numbers either way, bit for bit.
    """

    name: str
    init: Callable[[np.ndarray, np.ndarray], FilterState]
    step: Callable[..., tuple[FilterState, FilterInfo]]  # (rng_key, state, measure[, drawn=, shift=])
    evaluations_per_frame: int
    params: dict
    calls: tuple[int, ...] = ()
    draws: Callable[[jax.Array], object] | None = None


def moved(state: FilterState, shift: np.ndarray | None) -> FilterState:
    """``state`` with ``shift`` (D,) added to every particle (a new array); ``state`` for None.
    The filters that read every particle start with it; those that keep a few shift those."""
    if shift is None:
        return state
    return FilterState(state.particles + shift, state.weights)


def init_state(particles: np.ndarray, weights: np.ndarray) -> FilterState:
    return FilterState(np.asarray(particles, float), np.asarray(weights, float))


def gaussian_noise(rng_key: jax.Array, shape: tuple[int, ...], std: np.ndarray) -> np.ndarray:
    """White noise with per-column ``std`` (last axis), drawn from an explicit JAX key.

    Drawn in one call for the whole particle set, so the result never depends on chunking.
    """
    return np.asarray(standard_normal(rng_key, tuple(shape)), np.float64) * std


@functools.partial(Program, static_argnames=("shape",))
def standard_normal(rng_key: jax.Array, shape: tuple[int, ...]) -> jax.Array:
    """``jax.random.normal(rng_key, shape, float32)`` as one compiled call per shape: bit for bit
    the same numbers as the eager call, without its per-call dispatch of the key checks and the
    threefry primitives (2-3 ms a frame for 6561 x 27 draws)."""
    return jax.random.normal(rng_key, shape, dtype=jnp.float32)


def best_index(weights: np.ndarray) -> int:
    """Index of the heaviest particle; ties go to the lowest index (NaN never wins)."""
    w = np.where(np.isnan(weights), -np.inf, weights)
    return int(np.argmax(w))


def summarise(particles: np.ndarray, weights: np.ndarray, evaluations: int) -> FilterInfo:
    """Estimate (heaviest particle) and weighted mean of a weighted particle set."""
    i = best_index(weights)
    w = np.where(np.isfinite(weights), np.maximum(weights, 0.0), 0.0)
    total = w.sum()
    mean = particles[i] if total <= 0 else (w @ particles) / total  # no (N, D) temporary
    return FilterInfo(particles[i].copy(), float(weights[i]), mean, int(evaluations))


def rate_std(rates_per_s: np.ndarray, fps: float) -> np.ndarray:
    """Per-frame noise std from per-second rates: scaled by the frame interval 1/fps."""
    return np.asarray(rates_per_s, float) / float(fps)


def clip(limits: Limits, particles: np.ndarray) -> np.ndarray:
    return limits.clip(particles)


def default_noise_rates() -> np.ndarray:
    """(D,) per-second noise std of every DOF (metres/s, rad/s), shared by all filters.

    Set from how much each DOF changes between frames in normal walking (joint centres of a real
    marker walk, fitted with our model: trunk and arms 1-3 deg per 50 ms, hips 5, knees 8-9 rms):
    about 1.5x those rates. Every child particle gets this noise, so it also bounds how precise
    the heaviest particle can be; twice these rates tracked measurably worse. The root's
    translation is mostly explained by the body origin positioning (:mod:`ipf_jax.tracking.origin`), so its
    noise covers only the residual.
    Multiplied by 1/fps per frame.
    """
    from ..body.model import DOF_NAMES

    deg = np.deg2rad
    rates = {"root_tx": 0.15, "root_ty": 0.15, "root_tz": 0.1, "root_yaw": deg(20),
             "root_pitch": deg(15), "root_roll": deg(15)}
    for name in DOF_NAMES:
        if name in rates:
            continue
        if name.endswith(("hip_rotation", "trunk_rotation", "ankle_inversion")):
            # nearly unobservable in silhouettes (a pelvis turn can hide behind turned hips):
            # slow noise keeps such compensations from building up
            rates[name] = deg(8)
        elif name.startswith(("trunk", "head")) or name.endswith("hip_abduction"):
            rates[name] = deg(20)
        elif name.endswith("knee_flexion"):
            rates[name] = deg(100)
        else:  # hip flexion, ankle dorsiflexion, shoulders, elbows
            rates[name] = deg(50)
    return np.array([rates[n] for n in DOF_NAMES])


def resample_diffuse(rng_key: jax.Array | None, particles: np.ndarray, weights: np.ndarray,
                     std: np.ndarray, limits: Limits, num: int | None = None,
                     drawn: tuple[jax.Array, jax.Array] | None = None) -> np.ndarray:
    """Systematic resampling by ``weights`` then Gaussian diffusion of every DOF, clipped.

    The shared prediction of SIR and each APF layer. particles (N, D) -> (num, D). ``drawn``:
    ``resample_draws(rng_key, (num, D))`` made already (then ``rng_key`` is not used).
    """
    from .selection import systematic_at

    num = len(particles) if num is None else num
    u, z = drawn if drawn is not None else resample_draws(rng_key, (num, particles.shape[1]))
    idx = systematic_at(float(u), weights, num)
    # in place on one fresh array: the same numbers as ``clip(particles[idx] + z * std)``, without
    # the three more N x D temporaries (fresh pages cost more than the arithmetic at this size);
    # the float32 draws are widened inside the product (exactly, as a float64 copy of them was)
    out = np.multiply(np.asarray(z), std, dtype=np.float64)
    out += particles[idx]
    return limits.clip(out, copy=False)


def _resample_draws(rng_key: jax.Array, shape: tuple[int, int]) -> tuple[jax.Array, jax.Array]:
    """:func:`resample_diffuse`'s draws in one compiled call: the systematic offset
    ``uniform(k1, ())`` and ``normal(k2, shape)`` of ``k1, k2 = split(rng_key)``, bit for bit the
    numbers of the separate eager calls (:func:`~ipf_jax.filters.selection.systematic` and
    :func:`gaussian_noise` with those keys)."""
    k1, k2 = jax.random.split(rng_key)
    return jax.random.uniform(k1, ()), jax.random.normal(k2, shape, dtype=jnp.float32)


#: :func:`_resample_draws` as one compiled program per shape (its lowering kept on disk)
resample_draws = Program(_resample_draws, ("shape",))
