"""Annealed particle filter (Deutscher & Reid 2005): L layers of diffuse -> weigh -> anneal.

Per frame, starting from the previous frame's last layer, for layer m = 0 .. L-1:

1. resample by the annealed weights (systematic) and diffuse every DOF with Gaussian noise whose
   std is ``noise_scale x rates / fps`` times ``noise_decay ** m``;
2. weigh the N particles with the likelihood;
3. anneal: weights ``w ** beta`` with beta found (regula falsi) so that the effective sample
   fraction ``(sum w)^2 / (N sum w^2)`` equals the target survival rate alpha (default 0.5).

Deutscher & Reid shrink the diffusion covariance by the survival rate from one layer to the next,
so the default ``noise_decay`` is ``sqrt(alpha)`` on the std (bodytrack: sqrt(0.5) per layer too).
The state carries the last layer's raw likelihoods; the next frame re-anneals them (the same beta,
as the data are the same), so the tracker's best weight and confidence stay in likelihood units.

Estimates after the last layer: the heaviest particle (``FilterInfo.best``, what the tracker writes)
and the annealed-weight mean (``FilterInfo.mean``: Deutscher & Reid's and bodytrack's estimate).
"""
from __future__ import annotations

import functools
from typing import NamedTuple

import jax
import numpy as np

from ..body.limits import Limits
from ..body.model import NUM_DOF
from ..errors import require
from ..lowered import Program
from .base import (
    Filter,
    FilterState,
    default_noise_rates,
    init_state,
    moved,
    rate_std,
    resample_diffuse,
    resample_draws,
    summarise,
)

_MAX_BETA = 1e12  # beyond this every weight but the maxima underflows anyway


class APFSettings(NamedTuple):
    particles: int = 4000  # bodytrack's setting
    layers: int = 5
    survival: float = 0.5  # target effective sample fraction alpha per layer
    noise_scale: float = 1.0  # multiplies the default per-DOF noise rates
    noise_decay: float | None = None  # std multiplier per layer; None: sqrt(survival)


def validate(settings: APFSettings) -> None:
    require(settings.particles >= 1, f"APF needs at least one particle (got {settings.particles})")
    require(settings.layers >= 1, f"APF needs at least one layer (got {settings.layers})")
    require(0 < settings.survival < 1, f"survival fraction must be in (0, 1) (got {settings.survival})")
    require(0 <= settings.noise_scale < np.inf,
            f"noise scale must be >= 0 and finite (got {settings.noise_scale})")
    if settings.noise_decay is not None:
        require(0 < settings.noise_decay <= 1,
                f"noise decay per layer must be in (0, 1] (got {settings.noise_decay})")


def noise_decay(settings: APFSettings) -> float:
    """Noise std multiplier from one layer to the next (default sqrt(survival))."""
    return float(np.sqrt(settings.survival) if settings.noise_decay is None else settings.noise_decay)


def layer_scales(settings: APFSettings) -> np.ndarray:
    """(L,) noise std multiplier of each layer: 1, d, d^2, ... with d = :func:`noise_decay`."""
    return noise_decay(settings) ** np.arange(settings.layers)


def effective_fraction(w: np.ndarray, scratch: np.ndarray | None = None) -> float:
    """(sum w)^2 / (N sum w^2) of (N,) non-negative weights: 1 all equal, 1/N one survivor.
    ``scratch``: an (N,) buffer for ``w * w`` (a caller evaluating it many times)."""
    # np.add.reduce is np.sum's own pairwise sum without its wrappers (same bits, ~1.6 us less
    # a call: the annealing's bisection calls this ~60 times a layer)
    s2 = float(np.add.reduce(np.multiply(w, w, out=scratch)))
    return float(np.add.reduce(w)) ** 2 / (len(w) * s2) if s2 > 0 else 0.0


def _log_likelihood(likelihood: np.ndarray) -> np.ndarray:
    """(N,) log of the likelihoods; zero, negative or NaN ones are -inf (dead particles)."""
    lk = np.asarray(likelihood, float)
    ok = np.isfinite(lk) & (lk > 0)
    return np.where(ok, np.log(np.where(ok, lk, 1.0)), -np.inf)


def anneal_beta(likelihood: np.ndarray, target: float) -> float:
    """beta >= 0 with ``effective_fraction(likelihood ** beta) == target`` (dead particles count),
    to :data:`FRACTION_TOL`.

    likelihood : (N,) non-negative; zero/NaN entries are dead at every beta.
    The fraction falls monotonically from its value at beta = 0 (the live fraction) towards
    (number of maxima) / N. Returns 0 when it is already at or below ``target`` at beta = 0, or
    when all live likelihoods are equal (every beta gives the same weights); returns a very large
    beta when ties at the maximum keep it above ``target`` for every beta.

    The root is bracketed by doubling beta from 1, then found by Illinois' regula falsi on
    ``log(fraction / target)``, which falls smoothly with beta: 9 evaluations of the fraction on
    the mean over layers of 4000 silhouette-like likelihoods (a bisection to the last bit of beta
    took 33-36; each is an ``exp`` of every likelihood, scalar code in NumPy: docs/benchmarks.md).
    """
    lw = _log_likelihood(likelihood)
    live = np.isfinite(lw)
    if not live.any():
        return 0.0
    lw = lw[live] - lw[live].max()  # (N_live,) <= 0, so exp never overflows
    live_fraction = live.mean()
    w, w2 = np.empty_like(lw), np.empty_like(lw)  # one pair of buffers for every evaluation

    def log_ratio(beta: float) -> float:  # log(fraction / target) of np.exp(beta * lw), no new arrays
        f = live_fraction * effective_fraction(np.exp(np.multiply(beta, lw, out=w), out=w), w2)
        return float(np.log(f / target)) if f > 0 else -np.inf

    g_lo = log_ratio(0.0)
    if g_lo <= 0 or lw.min() == 0.0:
        return 0.0
    lo, hi = 0.0, 1.0
    while (g_hi := log_ratio(hi)) > 0:
        if hi >= _MAX_BETA:
            return hi
        lo, g_lo, hi = hi, g_hi, 2.0 * hi
    return _illinois(log_ratio, lo, g_lo, hi, g_hi)


#: :func:`anneal_beta` stops where the effective fraction is within this relative distance of the
#: target (its log within it of 0): far below any effect on the resampling (a systematic draw
#: would have to fall within 1e-9 of a weight's edge), far above the fraction's own rounding
#: (sums of a few thousand terms: ~1e-14)
FRACTION_TOL = 1e-9


def _illinois(g, a: float, g_a: float, b: float, g_b: float, steps: int = 200) -> float:
    """The root of the decreasing ``g`` in ``[a, b]`` (``g(a) > 0 >= g(b)``, ``g(b)`` may be -inf):
    Illinois' regula falsi (the kept end's value halved when the same end moves twice), a
    bisection step where the secant cannot be drawn; stops at ``|g| <= FRACTION_TOL`` or when the
    bracket is a few ulps wide."""
    side = 0
    for _ in range(steps):
        if b - a <= 4.0 * np.spacing(b):
            break
        x = (a * g_b - b * g_a) / (g_b - g_a) if np.isfinite(g_b) else 0.5 * (a + b)
        if not a < x < b:
            x = 0.5 * (a + b)
        g_x = g(x)
        if abs(g_x) <= FRACTION_TOL:
            return x
        if g_x > 0:
            a, g_a = x, g_x
            g_b, side = (0.5 * g_b if side > 0 else g_b), 1
        else:
            b, g_b = x, g_x
            g_a, side = (0.5 * g_a if side < 0 else g_a), -1
    return 0.5 * (a + b)


def annealed_weights(likelihood: np.ndarray, target: float) -> tuple[np.ndarray, float]:
    """(N,) weights ``(likelihood / max) ** beta`` (0 for dead particles) and that beta."""
    beta = anneal_beta(likelihood, target)
    lw = _log_likelihood(likelihood)
    if not np.isfinite(lw).any():
        return np.ones(len(lw)), beta  # nothing alive: resample uniformly
    return np.exp(beta * (lw - lw[np.isfinite(lw)].max())), beta


@functools.partial(Program, static_argnames=("layers", "shape"))
def layer_draws(rng_key: jax.Array, layers: int, shape: tuple[int, int]) -> tuple:
    """Every layer's resampling draws, ``resample_draws(fold_in(rng_key, layer), shape)``, in one
    compiled call (dispatched ahead of the frame by the tracker: see ``Filter.draws``)."""
    draw = resample_draws.fn  # the function itself: traced into this program
    return tuple(draw(jax.random.fold_in(rng_key, layer), shape) for layer in range(layers))


def build(settings: APFSettings, limits: Limits, fps: float) -> Filter:
    """The APF kernel for fixed settings: exactly ``particles x layers`` evaluations per frame."""
    validate(settings)
    std = rate_std(default_noise_rates(), fps) * settings.noise_scale  # (D,)
    scales = layer_scales(settings)  # (L,)
    n, layers = settings.particles, settings.layers

    def draws(rng_key: jax.Array) -> tuple:
        return layer_draws(rng_key, layers, (n, NUM_DOF))

    last = []  # [(likelihood, its annealed weights)] of the last layer of the last step

    def step(rng_key: jax.Array, state: FilterState, measure, drawn: tuple | None = None,
             shift: np.ndarray | None = None):
        x = moved(state, shift).particles
        if drawn is None or len(drawn) != layers or drawn[0][1].shape != (n, NUM_DOF):
            drawn = draws(rng_key)  # every layer's
        if last and np.array_equal(last[0][0], state.weights, equal_nan=True):
            pi = last[0][1]  # the previous step annealed these very weights last
        else:
            pi, _ = annealed_weights(state.weights, settings.survival)
        for layer, scale in enumerate(scales):
            x = resample_diffuse(None, x, pi, std * scale, limits, n, drawn[layer])  # (N, D)
            likelihood = np.asarray(measure(x), float)
            pi, _ = annealed_weights(likelihood, settings.survival)
        last[:] = [(likelihood.copy(), pi)]
        info = summarise(x, likelihood, n * layers)
        return FilterState(x, likelihood), info._replace(mean=summarise(x, pi, 0).mean)

    params = {"particles": n, "layers": layers, "survival": settings.survival,
              "noise_scale": settings.noise_scale,
              "noise_decay": noise_decay(settings)}
    return Filter("apf", init_state, step, n * layers, params, (n,) * layers, draws)
