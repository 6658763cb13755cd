"""Filter names -> builders, and the mapping of a likelihood budget onto each filter's parameters."""
from __future__ import annotations

from ..body.limits import Limits
from ..errors import IPFError, require
from . import apf, ipf, sir
from .base import Filter

NAMES = ("ipf", "apf", "sir")


def make(name: str, options: dict, limits: Limits, fps: float, budget: int | None = None) -> Filter:
    """Build filter ``name``. Explicit options win over the ``budget`` (evaluations per frame)."""
    if name not in NAMES:
        raise IPFError(f"unknown filter {name!r} (choose {', '.join(NAMES)})")
    if budget is not None:
        require(budget >= 1, f"budget must be >= 1 evaluation per frame (got {budget})")
    if name == "ipf":
        return _make_ipf(dict(options), limits, fps, budget)
    if name == "apf":
        return _make_apf(dict(options), limits, fps, budget)
    return _make_sir(dict(options), limits, fps, budget)


def _reject(options: dict, allowed: tuple[str, ...], name: str) -> None:
    extra = sorted(k for k, v in options.items() if v is not None and k not in allowed)
    require(not extra, f"option(s) {', '.join(extra)} do not apply to the {name} filter")


def _make_sir(options: dict, limits: Limits, fps: float, budget: int | None) -> Filter:
    _reject(options, ("particles", "noise_scale"), "sir")
    settings = sir.SIRSettings(**{k: v for k, v in options.items() if v is not None})
    if options.get("particles") is None and budget is not None:
        settings = settings._replace(particles=budget)
    f = sir.build(settings, limits, fps)
    _check_budget(f, budget)
    return f


def _make_apf(options: dict, limits: Limits, fps: float, budget: int | None) -> Filter:
    _reject(options, ("particles", "layers", "noise_scale", "survival"), "apf")
    settings = apf.APFSettings(**{k: v for k, v in options.items() if v is not None})
    if options.get("particles") is None and budget is not None:
        require(budget >= settings.layers, f"a budget of {budget} cannot feed {settings.layers} layers")
        settings = settings._replace(particles=budget // settings.layers)
    f = apf.build(settings, limits, fps)
    _check_budget(f, budget)
    return f


def _check_budget(f: Filter, budget: int | None) -> None:
    if budget is not None and f.evaluations_per_frame > budget:
        raise IPFError(f"{f.name} with {f.params} needs {f.evaluations_per_frame} evaluations per "
                       f"frame, over the budget of {budget}")


def _make_ipf(options: dict, limits: Limits, fps: float, budget: int | None) -> Filter:
    _reject(options, ("particles", "top_m", "points_per_dof", "interesting", "max_speed_deg_s",
                      "interval_width_deg", "noise_scale"), "ipf")
    particles = options.pop("particles", None)
    settings = ipf.IPFSettings(**{k: v for k, v in options.items() if v is not None})
    grid = settings.grid_size()
    if "top_m" not in options or options.get("top_m") is None:
        total = particles if particles is not None else budget
        if total is not None:
            require(total >= grid, f"{total} particles cannot hold one grid of I = {grid} neighbours "
                    f"({settings.points_per_dof} points per DOF over {len(settings.interesting)} DOF)")
            settings = settings._replace(top_m=total // grid)
    elif particles is not None:
        raise IPFError("give either --particles or --top-m, not both")
    f = ipf.build(settings, limits, fps)
    _check_budget(f, budget)
    return f
