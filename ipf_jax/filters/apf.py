"""Annealed particle filter (Deutscher & Reid 2005): L layers of diffuse -> weigh -> anneal.

Per frame, starting from the previous frame's last layer, for layer m = 0 .. L-1:

1. resample by the annealed weights (systematic) and diffuse every DOF with Gaussian noise whose
   std is ``noise_scale x rates / fps`` times ``noise_decay ** m``;
2. weigh the N particles with the likelihood;
3. anneal: weights ``w ** beta`` with beta chosen by bisection so that the effective sample
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


def anneal_beta(likelihood: np.ndarray, target: float, *, iters: int = 64) -> float:
    """beta >= 0 with ``effective_fraction(likelihood ** beta) == target`` (dead particles count).

    likelihood : (N,) non-negative; zero/NaN entries are dead at every beta.
    The fraction falls monotonically from its value at beta = 0 (the live fraction) towards
    (number of maxima) / N. Returns 0 when it is already at or below ``target`` at beta = 0, or
    when all live likelihoods are equal (every beta gives the same weights); returns a very large
    beta when ties at the maximum keep it above ``target`` for every beta.
    """
    lw = _log_likelihood(likelihood)
    live = np.isfinite(lw)
    if not live.any():
        return 0.0
    lw = lw[live] - lw[live].max()  # (N_live,) <= 0, so exp never overflows
    live_fraction = live.mean()
    w, w2 = np.empty_like(lw), np.empty_like(lw)  # one pair of buffers for every evaluation

    def fraction(beta: float) -> float:  # effective_fraction(np.exp(beta * lw)), without new arrays
        return live_fraction * effective_fraction(np.exp(np.multiply(beta, lw, out=w), out=w), w2)

    f_lo = fraction(0.0)
    if f_lo <= target or lw.min() == 0.0:
        return 0.0
    lo, hi = 0.0, 1.0
    while (f_hi := fraction(hi)) > target:
        if hi >= _MAX_BETA:
            return hi
        lo, f_lo, hi = hi, f_hi, 2.0 * hi
    # the bisection's every decision outside a bracket [a, b] of the root is known (the fraction
    # falls with beta): a few regula falsi steps find one, and only midpoints inside it are
    # evaluated (34 evaluations instead of 57 on a layer of 4000, the same beta to the last bit)
    a, b = _bracket(fraction, target, lo, f_lo, hi, f_hi)
    for _ in range(iters):
        mid = 0.5 * (lo + hi)
        right = mid <= a or (mid < b and fraction(mid) > target)
        step = (mid, hi) if right else (lo, mid)
        if step == (lo, hi):  # mid is lo or hi: every later step would repeat this one
            break
        lo, hi = step
    return 0.5 * (lo + hi)


#: A bound of :func:`_bracket` must have its log fraction this far from the target's: the
#: evaluated fraction is monotone in beta to ~1e-14 (sums of a few thousand terms), so the
#: bisection's own evaluation beyond the bound could not decide otherwise.
_BRACKET_MARGIN = 1e-11


def _bracket(fraction, target: float, lo: float, f_lo: float, hi: float, f_hi: float,
             steps: int = 16) -> tuple:
    """(a, b), lo <= a < root <= b <= hi: fraction(a) > target and fraction(b) <= target, each by
    :data:`_BRACKET_MARGIN` (in log) unless it is ``lo`` or ``hi`` (the bisection's own ends,
    which no midpoint reaches). Illinois' regula falsi on log(fraction / target); a step that
    lands too near the root to bound it is followed by one probe on each side of it
    (:func:`_probe_sides`), so that the bisection starts inside a bracket a few margins wide
    instead of at the last bounds that regula falsi kept."""
    a, b = lo, hi
    g_a, g_b = np.log(f_lo / target), np.log(f_hi / target) if f_hi > 0 else -np.inf
    side = 0
    for _ in range(steps):
        if not np.isfinite(g_b) or b - a <= 1e-12 * b:
            break
        x = (a * g_b - b * g_a) / (g_b - g_a)
        if not a < x < b:
            x = 0.5 * (a + b)
        f_x = fraction(x)
        g_x = np.log(f_x / target) if f_x > 0 else -np.inf
        if g_x > _BRACKET_MARGIN:
            a, g_a = x, g_x
            g_b, side = (0.5 * g_b if side > 0 else g_b), 1
        elif g_x < -_BRACKET_MARGIN:
            b, g_b = x, g_x
            g_a, side = (0.5 * g_a if side < 0 else g_a), -1
        else:  # too near the root to bound it safely: bound it from both sides of x
            return _probe_sides(fraction, target, a, g_a, b, g_b, x)
    return a, b


def _probe_sides(fraction, target: float, a: float, g_a: float, b: float, g_b: float,
                 x: float) -> tuple:
    """The bracket (a, b) tightened around ``x``, a point within the margin of the root: one
    evaluation each at ``x -+ d``, ``d`` four margins' worth of beta at the secant's slope, each
    kept as a bound only where its log fraction clears the margin (the same rule as
    :func:`_bracket`'s; a probe that does not is one evaluation lost, the bracket as it was)."""
    slope = abs((g_b - g_a) / (b - a)) if np.isfinite(g_b) and b > a else 0.0
    if not slope > 0.0:
        return a, b
    d = max(4.0 * _BRACKET_MARGIN / slope, 8.0 * np.spacing(x))
    for p in (x - d, x + d):
        if not a < p < b:
            continue
        f_p = fraction(p)
        g_p = np.log(f_p / target) if f_p > 0 else -np.inf
        if g_p > _BRACKET_MARGIN:
            a = p
        elif g_p < -_BRACKET_MARGIN:
            b = p
    return a, b


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

    def step(rng_key: jax.Array, state: FilterState, measure, drawn: tuple | None = None):
        x = state.particles
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
