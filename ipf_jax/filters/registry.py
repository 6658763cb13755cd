"""Filter names -> builders, and the mapping of a likelihood budget onto each filter's parameters.

A budget is a number of likelihood evaluations per frame. Each filter fills the parameters the
user did not give so that it spends as much of the budget as it can without exceeding it:

========  =====================================================================================
ipf       M = budget // I (I = P^|L| grid points; ``particles`` stands for M x I the same way)
apf       particles = budget // layers; or, with ``particles`` given, layers = budget // particles
sir       particles = budget
========  =====================================================================================

Explicit parameters win over the mapping; if they need more than the budget, that is an
:class:`~ipf_jax.errors.IPFError` (the budget is a ceiling, never exceeded silently).
"""
from __future__ import annotations

import numbers

from ..body.limits import Limits
from ..errors import IPFError, require
from . import apf, ipf, sir
from .base import Filter

NAMES = ("ipf", "apf", "sir")

#: The options each filter understands (keys of ``make``'s ``options``).
OPTIONS: dict[str, tuple[str, ...]] = {
    "ipf": ("particles", "top_m", "points_per_dof", "interesting", "max_speed_deg_s",
            "interval_width_deg", "noise_scale"),
    "apf": ("particles", "layers", "survival", "noise_scale", "noise_decay"),
    "sir": ("particles", "noise_scale"),
}


def check_name(name: str) -> None:
    if name not in NAMES:
        raise IPFError(f"unknown filter {name!r} (choose {', '.join(NAMES)})")


def options_for(name: str, options: dict) -> dict:
    """The subset of ``options`` (None values dropped) that filter ``name`` understands."""
    check_name(name)
    return {k: v for k, v in options.items() if v is not None and k in OPTIONS[name]}


def make(name: str, options: dict, limits: Limits, fps: float, budget: int | None = None) -> Filter:
    """Build filter ``name``. Explicit options win over the ``budget`` (evaluations per frame)."""
    check_name(name)
    if budget is not None:
        require(isinstance(budget, numbers.Integral) and not isinstance(budget, bool) and budget >= 1,
                f"budget must be a whole number >= 1 of evaluations per frame (got {budget!r})")
        budget = int(budget)
    options = {k: v for k, v in options.items() if v is not None}
    extra = sorted(set(options) - set(OPTIONS[name]))
    require(not extra, f"option(s) {', '.join(extra)} do not apply to the {name} filter")
    f = {"ipf": _make_ipf, "apf": _make_apf, "sir": _make_sir}[name](options, limits, fps, budget)
    if budget is not None and f.evaluations_per_frame > budget:
        raise IPFError(f"{name} with {', '.join(f'{k}={v}' for k, v in options.items())} needs "
                       f"{f.evaluations_per_frame} evaluations per frame, over the budget of {budget}")
    return f


def _make_sir(options: dict, limits: Limits, fps: float, budget: int | None) -> Filter:
    settings = sir.SIRSettings(**options)
    if "particles" not in options and budget is not None:
        settings = settings._replace(particles=budget)
    return sir.build(settings, limits, fps)


def _make_apf(options: dict, limits: Limits, fps: float, budget: int | None) -> Filter:
    settings = apf.APFSettings(**options)
    if budget is not None and "particles" not in options:
        require(budget >= settings.layers,
                f"a budget of {budget} evaluations cannot feed {settings.layers} layers")
        settings = settings._replace(particles=budget // settings.layers)
    elif budget is not None and "layers" not in options:
        require(budget >= settings.particles,
                f"a budget of {budget} evaluations cannot weigh {settings.particles} particles once")
        settings = settings._replace(layers=budget // settings.particles)
    return apf.build(settings, limits, fps)


def _make_ipf(options: dict, limits: Limits, fps: float, budget: int | None) -> Filter:
    options = dict(options)
    particles = options.pop("particles", None)
    if particles is not None and "top_m" in options:
        raise IPFError("give either --particles or --top-m, not both")
    settings = ipf.IPFSettings(**options)
    total = particles if particles is not None else (None if "top_m" in options else budget)
    if total is not None:
        grid = settings.grid_size()
        require(total >= grid, f"{total} particles cannot hold one grid of I = {grid} neighbours "
                f"({settings.points_per_dof} points per DOF over {len(settings.interesting)} DOF)")
        settings = settings._replace(top_m=total // grid)
    return ipf.build(settings, limits, fps)
