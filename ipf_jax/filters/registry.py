"""Filter names -> settings and builders, and the mapping of a likelihood budget onto each filter.

A budget is a number of likelihood evaluations per frame. Each filter fills the parameters the
user did not give so that it spends as much of the budget as it can without exceeding it:

========  =====================================================================================
ipf       M = budget // I (I = P^|L| grid points; ``particles`` stands for M x I the same way)
fipf      the polish first (6 compass sweeps of one particle: 378; and the arms' reach search
          when on: 204), then M = the rest //
          (rounds x sum of the group grids, the posture group's 27 with a body); the remainder
          is ``filler`` (noisy copies), so the budget is spent exactly (``particles`` stands for
          the budget); with neither, the paper's 6561. Below 1206 (the polish and one particle's
          3-point grids), unless given: no polish; below 828, 2 points (184), then 2 points and
          1 round (92); without a body 1152, 774, 168 and 84
apf       particles = budget // layers; or, with ``particles`` given, layers = budget // particles
sir       particles = budget
========  =====================================================================================

Explicit parameters win over the mapping; if they need more than the budget, that is an
:class:`~ipf_jax.errors.IPFError` (the budget is a ceiling, never exceeded silently).
:func:`resolve` does all of that on the settings alone (cheap: nothing is built), :func:`make`
builds the filter from them. The options each filter takes are its settings' fields
(:data:`OPTIONS`), so they are declared once, with their defaults, in the filter's module.
"""
from __future__ import annotations

import numbers
from typing import NamedTuple

from ..body.limits import Limits
from ..errors import IPFError, require
from . import apf, fipf, ipf, posture, reach, sir
from .base import Filter

NAMES = ("ipf", "fipf", "apf", "sir")
#: The filter a run uses unless told: chosen by measurement over every visible walk (docs/fipf.md).
DEFAULT = "fipf"
_MODULES = {"ipf": ipf, "fipf": fipf, "apf": apf, "sir": sir}
#: Likelihood evaluations per frame beyond which a setting is refused: 50x the largest budget in
#: use (20000); 10^10 SIR particles waited for ever on an allocation that could not be made.
MAX_EVALUATIONS = 1_000_000
SETTINGS = {"ipf": ipf.IPFSettings, "fipf": fipf.FIPFSettings, "apf": apf.APFSettings,
            "sir": sir.SIRSettings}

#: The options each filter understands (keys of ``make``'s ``options``): its settings' fields, and
#: ``particles`` (for IPF: N = M x I).
OPTIONS: dict[str, tuple[str, ...]] = {
    name: tuple(dict.fromkeys(("particles", *cls._fields))) for name, cls in SETTINGS.items()}


def check_name(name: str) -> None:
    if name not in NAMES:
        raise IPFError(f"unknown filter {name!r} (choose {', '.join(NAMES)})")


def defaults(name: str) -> dict:
    """Filter ``name``'s default settings (option -> value)."""
    check_name(name)
    return SETTINGS[name]()._asdict()


def options_for(name: str, options: dict) -> dict:
    """The subset of ``options`` (None values dropped) that filter ``name`` understands."""
    check_name(name)
    return {k: v for k, v in options.items() if v is not None and k in OPTIONS[name]}


def evaluations(name: str, settings: NamedTuple) -> int:
    """Likelihood evaluations per frame of filter ``name`` with ``settings``."""
    return {"ipf": lambda s: s.top_m * s.grid_size(), "fipf": lambda s: s.evaluations(), "apf": lambda s: s.particles * s.layers,
            "sir": lambda s: s.particles}[name](settings)


def resolve(name: str, options: dict, fps: float, budget: int | None = None,
            views: int | None = None) -> NamedTuple:
    """The validated settings of filter ``name``: ``options`` (explicit, win) and the ``budget``
    (evaluations per frame) mapped as the module doc says. ``views`` (the recording's cameras)
    sets the factored filter's posture group and arms' reach search by default
    (:func:`_camera_rules`; a budget too small for the reach search drops it like the polish, an
    explicit ``reach`` is kept or is an error).
    Raises IPFError for any impossible combination, without building anything."""
    check_name(name)
    if budget is not None:
        require(isinstance(budget, numbers.Integral) and not isinstance(budget, bool) and budget >= 1,
                f"budget must be a whole number >= 1 of evaluations per frame (got {budget!r})")
        budget = int(budget)
    options = {k: v for k, v in options.items() if v is not None}
    extra = sorted(set(options) - set(OPTIONS[name]))
    require(not extra, f"option(s) {', '.join(extra)} do not apply to the {name} filter")
    if name == "fipf":
        settings = _fipf_settings(options, budget, views)
    else:
        settings = {"ipf": _ipf_settings, "apf": _apf_settings, "sir": _sir_settings}[name](options, budget)
    _MODULES[name].validate(settings)
    need = evaluations(name, settings)
    require(need <= MAX_EVALUATIONS, f"{name} would make {need} likelihood evaluations per frame, "
            f"more than {MAX_EVALUATIONS} (minutes a frame, gigabytes of particles)")
    if budget is not None and need > budget:
        raise IPFError(f"{name} with {', '.join(f'{k}={v}' for k, v in options.items())} needs "
                       f"{need} evaluations per frame, over the budget of {budget}")
    return settings


def make(name: str, options: dict, limits: Limits, fps: float, budget: int | None = None,
         body: posture.Body | None = None, views: int | None = None) -> Filter:
    """Build filter ``name``. Explicit options win over the ``budget`` (evaluations per frame).
    ``body`` (the subject's shape values and up rotation) lets the factored filter search its
    posture group (:mod:`.posture`); without one that group is off (asking for it is an error)."""
    if name == "fipf" and body is None:
        require(not options.get("posture"), "the factored filter's posture group needs the body "
                "(the tracker gives it)")
        options = {**options, "posture": False}
    settings = resolve(name, options, fps, budget, views)
    return (fipf.build(settings, limits, fps, body) if name == "fipf"
            else _MODULES[name].build(settings, limits, fps))


def _sir_settings(options: dict, budget: int | None) -> sir.SIRSettings:
    settings = sir.SIRSettings(**options)
    if "particles" not in options and budget is not None:
        settings = settings._replace(particles=budget)
    return settings


def _apf_settings(options: dict, budget: int | None) -> apf.APFSettings:
    settings = apf.APFSettings(**options)
    apf.validate(settings)  # the given sizes first: a budget is divided by them
    if budget is not None and "particles" not in options:
        require(budget >= settings.layers,
                f"a budget of {budget} evaluations cannot feed {settings.layers} layers")
        settings = settings._replace(particles=budget // settings.layers)
    elif budget is not None and "layers" not in options:
        require(budget >= settings.particles,
                f"a budget of {budget} evaluations cannot weigh {settings.particles} particles once")
        settings = settings._replace(layers=budget // settings.particles)
    return settings


def _sized(options: dict, budget: int | None, fallback: int | None = None) -> tuple[dict, int | None]:
    """(options without ``particles``, the total to size M from): ``particles``, else the budget
    unless M is given (else ``fallback``). Giving both ``particles`` and M is an error."""
    options = dict(options)
    particles = options.pop("particles", None)
    if particles is not None and "top_m" in options:
        raise IPFError("give either --particles or --top-m, not both")
    if particles is not None or "top_m" in options:
        return options, particles
    return options, budget if budget is not None else fallback


def _ipf_settings(options: dict, budget: int | None) -> ipf.IPFSettings:
    options, total = _sized(options, budget)
    settings = ipf.IPFSettings(**options)
    ipf.validate(settings)  # the given sizes first: the total is divided by the grid
    if total is not None:
        grid = settings.grid_size()
        require(total >= grid, f"{total} particles cannot hold one grid of I = {grid} neighbours "
                f"({settings.points_per_dof} points per DOF over {len(settings.interesting)} DOF)")
        settings = settings._replace(top_m=total // grid)
    return settings


def _camera_rules(views: int | None) -> dict:
    """The factored filter's searches that are on by default only with enough cameras: the
    posture group (:data:`.posture.MIN_VIEWS`) and the arms' reach search
    (:data:`.reach.MIN_VIEWS`); nothing when the number of cameras is not given."""
    if views is None:
        return {}
    return {"posture": views >= posture.MIN_VIEWS, "reach": views >= reach.MIN_VIEWS}


def _fipf_settings(options: dict, budget: int | None, views: int | None = None) -> fipf.FIPFSettings:
    options, total = _sized(options, budget, fipf.DEFAULT_BUDGET)  # no size given: the paper's
    settings = fipf.FIPFSettings(**{**_camera_rules(views), **options})
    fipf.validate(settings)  # the given sizes first: the total is divided by the grids
    if total is not None:
        for fallback in ({"polish": 0, "reach": False}, {"polish": 0, "reach": False, "points_per_dof": 2},
                         {"polish": 0, "reach": False, "points_per_dof": 2, "rounds": 1}):
            if total - settings.fixed_cost() >= settings.cost_per_particle() or set(fallback) & set(options):
                break  # small budgets: no polish, then coarser grids, unless the user chose them
            settings = settings._replace(**fallback)
        cost, rest = settings.cost_per_particle(), total - settings.fixed_cost()
        require(rest >= cost, f"{total} evaluations cannot search the groups once per kept particle "
                f"(the factored filter needs {cost} per kept particle: {settings.rounds} round(s) "
                f"over grids of {'+'.join(map(str, settings.grid_sizes()))}"
                + (f"; its polish takes {settings.polish_cost()}" if settings.polish else "")
                + (f"; its reach search {settings.reach_cost()}" if settings.reach else "") + ")")
        settings = settings._replace(top_m=rest // cost, filler=rest % cost)
    return settings
