"""Factored Interval Particle Filtering: IPF's deterministic interval search, group by group.

After Saboune, Rose & Charpillet, *Factored Interval Particle Filtering for Gait Analysis* (EMBC
2007): the state is split into weakly coupled groups (root, trunk, each leg, each arm, head) and
the groups are searched **in turn**, each over its own interval grid around the current particles
with the other groups held at their current values. The M best distinct particles are kept after
each group, so the cost is M x the *sum* of the group grids, not their product, and every limb
gets a deterministic search instead of IPF's white noise. Per frame (pseudo-code and sizing in
``docs/fipf.md``)::

    kept <- the M heaviest distinct particles of the previous frame
    for round r = 0 .. rounds-1:                     # coarse to fine: widths x shrink ** r
        for group g in groups:
            children <- for each kept particle, its grid over g's grid DOFs (P points per DOF,
                        centre included), g's noise DOFs jittered (not the centre child);
                        in round 0, group 0 also gets ``filler`` noisy copies (all DOFs)
            weigh the children;  kept <- the M heaviest distinct children
    reach (with ``reach``): one arm, drawn, over its whole range from the best (.reach)
    polish: compass sweeps from the best (``polish``)
    estimate <- the heaviest particle weighed this frame

The grid of DOF d spans ``+- speed_d / fps`` (x ``speed_scale``, x ``shrink ** r``): a
physiological maximum angular speed per DOF (:data:`MAX_SPEEDS`, with sources), not one width for
all. The evaluations per frame are exactly ``M x rounds x sum(P ** |grid_g|) + filler`` plus the
polish's and the reach's; with a budget, M is the largest that fits and the remainder is the
``filler`` (so the budget is spent exactly, never exceeded).
"""
from __future__ import annotations

import functools
import itertools
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from ..body.limits import Limits
from ..body.model import DOF_INDEX, DOF_NAMES, NUM_DOF
from ..errors import require
from ..lowered import Program
from .base import (
    Filter,
    FilterState,
    default_noise_rates,
    gaussian_noise,
    init_state,
    rate_std,
    summarise,
)
from . import posture, reach
from .compass import SEARCH_STD, compass_search, sweep_cost
from .selection import top_distinct

#: (name, DOFs searched on the grid, DOFs that only get noise). Every DOF is in exactly one group.
#: The nearly unobservable rotations (hip, trunk, shoulder rotation, ankle inversion) get noise only;
#: the root's three translations are all on the grid (whatever the up axis).
GROUPS: tuple[tuple[str, tuple[str, ...], tuple[str, ...]], ...] = (
    ("root", ("root_tx", "root_ty", "root_tz", "root_yaw"), ()),
    ("trunk", ("root_pitch", "root_roll", "trunk_flexion", "trunk_lateral"), ("trunk_rotation",)),
    ("left_leg", ("left_hip_flexion", "left_hip_abduction", "left_knee_flexion",
                  "left_ankle_dorsiflexion"), ("left_hip_rotation", "left_ankle_inversion")),
    ("right_leg", ("right_hip_flexion", "right_hip_abduction", "right_knee_flexion",
                   "right_ankle_dorsiflexion"), ("right_hip_rotation", "right_ankle_inversion")),
    ("left_arm", ("left_shoulder_flexion", "left_shoulder_abduction", "left_elbow_flexion"),
     ("left_shoulder_rotation",)),
    ("right_arm", ("right_shoulder_flexion", "right_shoulder_abduction", "right_elbow_flexion"),
     ("right_shoulder_rotation",)),
    ("head", ("head_flexion", "head_lateral"), ()),
)

#: Maximum speed of each grid DOF in everyday movement (walking, turning, rising from a chair),
#: deg/s (root translation: m/s, the residual after the body origin positioning). Sources:
#: sagittal lower-limb angular velocities of walking at 0.4-1.6 m/s peak near 350-400 deg/s at the
#: knee in swing, ~250-300 deg/s at the ankle at push-off and ~200 deg/s at the hip (Mentiplay et
#: al., "Lower limb angular velocity during walking at various speeds", Gait & Posture 65, 2018;
#: Winter, *The Biomechanics and Motor Control of Human Gait*, 1987); rising from a chair moves
#: trunk, hip and knee at ~60-150 deg/s (Schenkman et al., "Whole-body movements during rising to
#: standing from sitting", Phys Ther 70, 1990); the body turns in a step or spin turn within about
#: one step (Hase & Stein, "Turning strategies during human walking", J Neurophysiol 81, 1999):
#: 90 deg in ~0.5 s; arm swing in walking (Meyns, Bruijn & Duysens, "The how and why of arm swing
#: during human walking", Gait & Posture 38, 2013): shoulder and elbow well under 200 deg/s.
#: Frontal-plane DOFs (abduction, pelvis roll, trunk lateral) move far less. ``speed_scale``
#: multiplies them all.
MAX_SPEEDS: dict[str, float] = {
    "root_tx": 0.4, "root_ty": 0.4, "root_tz": 0.4, "root_yaw": 200.0,
    "root_pitch": 100.0, "root_roll": 60.0, "trunk_flexion": 120.0, "trunk_lateral": 60.0,
    "hip_flexion": 250.0, "hip_abduction": 100.0, "knee_flexion": 400.0,
    "ankle_dorsiflexion": 300.0,
    "shoulder_flexion": 150.0, "shoulder_abduction": 100.0, "elbow_flexion": 200.0,
    "head_flexion": 100.0, "head_lateral": 100.0,
}


def max_speed(dof: str) -> float:
    """The maximum speed of ``dof`` (deg/s, or m/s for root translation), by side-free name."""
    key = dof.removeprefix("left_").removeprefix("right_")
    require(key in MAX_SPEEDS, f"no maximum speed for DOF {dof}")
    return MAX_SPEEDS[key]


#: Evaluations per frame when neither a budget nor M is given: the paper's IPF (81 x 3^4).
DEFAULT_BUDGET = 6561


class FIPFSettings(NamedTuple):
    top_m: int = 8
    points_per_dof: int = 3
    rounds: int = 2  # passes over all groups per frame, each finer by ``shrink``
    shrink: float = 1.0 / 3.0
    speed_scale: float = 1.0  # multiplies every MAX_SPEEDS entry
    noise_scale: float = 1.0  # multiplies the default per-DOF noise rates of the noise DOFs
    filler: int = 0  # extra noisy copies weighed with the first group (spends a budget exactly)
    groups: tuple = GROUPS
    polish: int = 6  # compass sweeps from the best particle after the rounds (0: none; docs/fipf.md)
    polish_keep: int = 1  # distinct particles each polish sweep starts from
    polish_step: float = 0.25  # the first sweep's steps, as a fraction of compass.SEARCH_STD
    posture: bool = True  # the posture group after the trunk's (.posture; needs the body)
    reach: bool = False  # an arm a frame searched over its whole range after the rounds (.reach)

    def stages(self) -> tuple[str, ...]:
        """The names of the searches of a round, in order: the groups, and the posture group
        after the trunk's (after the first group when there is no trunk group)."""
        names = [name for name, _, _ in self.groups]
        if self.posture:
            names.insert(names.index("trunk") + 1 if "trunk" in names else 1, posture.NAME)
        return tuple(names)

    def grid_sizes(self) -> tuple[int, ...]:
        """Grid points of each search of a round (:meth:`stages`' order)."""
        size = {name: self.points_per_dof ** len(grid) for name, grid, _ in self.groups}
        size[posture.NAME] = self.points_per_dof ** 3
        return tuple(size[name] for name in self.stages())

    def cost_per_particle(self) -> int:
        """Evaluations per kept particle per frame: rounds x the sum of the group grids."""
        return self.rounds * sum(self.grid_sizes())

    def polish_cost(self) -> int:
        """Evaluations of the polish: ``polish`` compass sweeps of ``polish_keep`` particles."""
        return self.polish * sweep_cost(self.polish_keep)

    def reach_cost(self) -> int:
        """Evaluations of the arms' reach search (:func:`.reach.cost`; 0 when off)."""
        return reach.cost() if self.reach else 0

    def fixed_cost(self) -> int:
        """Evaluations a frame spends whatever M: the polish and the reach search."""
        return self.polish_cost() + self.reach_cost()

    def evaluations(self) -> int:
        return self.top_m * self.cost_per_particle() + self.filler + self.fixed_cost()

    def calls(self) -> tuple[int, ...]:
        """Particles of each measure call of a frame: one per group and round (the filler with
        the first), the reach search's (:func:`.reach.calls`), then two per polish sweep (the
        moves, the combined moves)."""
        sizes = [self.top_m * g for _ in range(self.rounds) for g in self.grid_sizes()]
        sizes[0] += self.filler
        return (tuple(sizes) + (reach.calls() if self.reach else ())
                + (2 * NUM_DOF * self.polish_keep, self.polish_keep) * self.polish)


def validate(settings: FIPFSettings) -> None:
    require(settings.top_m >= 1, f"top M must be >= 1 (got {settings.top_m})")
    require(settings.points_per_dof >= 1, f"points per DOF must be >= 1 (got {settings.points_per_dof})")
    require(settings.rounds >= 1, f"rounds must be >= 1 (got {settings.rounds})")
    require(0 < settings.shrink <= 1, f"shrink must be in (0, 1] (got {settings.shrink})")
    require(0 < settings.speed_scale < np.inf,
            f"speed scale must be > 0 and finite (got {settings.speed_scale})")
    require(0 <= settings.noise_scale < np.inf,
            f"noise scale must be >= 0 and finite (got {settings.noise_scale})")
    require(settings.filler >= 0, f"filler must be >= 0 (got {settings.filler})")
    require(settings.polish >= 0, f"polish sweeps must be >= 0 (got {settings.polish})")
    require(settings.polish_keep >= 1, f"polish keep must be >= 1 (got {settings.polish_keep})")
    require(settings.polish_step > 0, f"polish step must be > 0 (got {settings.polish_step})")
    require(all(name != posture.NAME for name, _, _ in settings.groups),
            f"a group may not be called {posture.NAME!r} (the posture group's name)")
    named = [d for _, grid, noise in settings.groups for d in (*grid, *noise)]
    unknown = [d for d in named if d not in DOF_INDEX]
    require(not unknown, f"unknown DOF in the groups: {', '.join(unknown)}")
    require(sorted(named) == sorted(DOF_NAMES), "the groups must hold every DOF exactly once")
    for _, grid, _ in settings.groups:
        for d in grid:
            max_speed(d)


def group_grid(grid_dofs: tuple[str, ...], settings: FIPFSettings, fps: float) -> np.ndarray:
    """(P^|g|, |g|) offsets of one group's grid, round 0 (radians; metres for translation).
    The centre (all zeros) is row (P^|g| - 1) // 2 for odd P."""
    half = np.array([max_speed(d) * settings.speed_scale / fps for d in grid_dofs])
    half = np.where([d in ("root_tx", "root_ty", "root_tz") for d in grid_dofs], half, np.deg2rad(half))
    p = settings.points_per_dof
    axis = np.zeros(1) if p == 1 else np.linspace(-1.0, 1.0, p)
    return np.array(list(itertools.product(axis, repeat=len(grid_dofs)))) * half


class _Stage(NamedTuple):
    name: str
    grid_idx: np.ndarray  # (|g|,) DOF indices on the grid
    noise_idx: np.ndarray  # (|n|,) DOF indices that get noise
    offsets: np.ndarray  # (G, |g|) round-0 grid offsets
    noise_std: np.ndarray  # (|n|,) round-0 noise std per frame
    centre: np.ndarray  # (G,) bool: the grid's centre child (kept without noise)


def _stages(settings: FIPFSettings, fps: float) -> list[_Stage]:
    """The searches of a round in order; the posture group's offsets are its own (forward, up,
    pitch: :func:`.posture.grid`), with no DOF indices and no noise."""
    std = rate_std(default_noise_rates(), fps) * settings.noise_scale
    groups = {name: (grid, noise) for name, grid, noise in settings.groups}
    out = []
    for name in settings.stages():
        if name == posture.NAME:
            offsets = posture.grid(settings.points_per_dof, fps, settings.speed_scale)
            none = np.zeros(0, int)
            out.append(_Stage(name, none, none, offsets, np.zeros(0), np.all(offsets == 0, axis=1)))
            continue
        grid, noise = groups[name]
        offsets = group_grid(grid, settings, fps)
        out.append(_Stage(name, np.array([DOF_INDEX[d] for d in grid], int),
                          np.array([DOF_INDEX[d] for d in noise], int), offsets,
                          std[[DOF_INDEX[d] for d in noise]], np.all(offsets == 0, axis=1)))
    return out


@functools.partial(Program, static_argnames=("n_keys", "shapes"))
def _split_and_draw(rng_key: jax.Array, n_keys: int, shapes: tuple) -> tuple:
    """A frame's keys and draws in one compiled call: ``keys = jax.random.split(rng_key, n_keys)``
    and ``jax.random.normal(keys[i], shape)`` for each ``(i, shape)`` of ``shapes``, bit for bit
    what the eager calls give (one dispatch, not 12)."""
    keys = jax.random.split(rng_key, n_keys)
    return keys, tuple(jax.random.normal(keys[i], s, dtype=jnp.float32) for i, s in shapes)


def _children(keys: jax.Array, i: int, kept: np.ndarray, stage: _Stage, scale: float,
              z: np.ndarray | None = None) -> np.ndarray:
    """(M x G, D) children of the kept particles over one group's grid (scaled by ``scale``),
    the noise DOFs jittered with ``keys[i]``'s standard normals: ``z`` when drawn already."""
    m, g = len(kept), len(stage.offsets)
    new = np.repeat(kept, g, axis=0)  # child j*G + k = kept j, grid point k
    new[:, stage.grid_idx] += np.tile(stage.offsets * scale, (m, 1))
    if len(stage.noise_idx):
        shape = (m * g, len(stage.noise_idx))
        jitter = (np.asarray(z, np.float64) * (stage.noise_std * scale)
                  if z is not None and z.shape == shape
                  else gaussian_noise(keys[i], shape, stage.noise_std * scale))
        jitter[np.tile(stage.centre, m)] = 0.0  # the centre child is the kept particle itself
        new[:, stage.noise_idx] += jitter
    return new


def _params(settings: FIPFSettings) -> dict:
    """What ``run.json`` records of the factored filter's settings (``filter_params``)."""
    return {"top_m": settings.top_m, "points_per_dof": settings.points_per_dof, "rounds": settings.rounds,
            "shrink": settings.shrink, "speed_scale": settings.speed_scale,
            "noise_scale": settings.noise_scale, "filler": settings.filler,
            "groups": {name: list(grid) for name, grid, _ in settings.groups},
            "posture": settings.posture, "reach": settings.reach,
            "reach_cost": settings.reach_cost(), "stages": list(settings.stages()),
            "grid_sizes": list(settings.grid_sizes()),
            "cost_per_particle": settings.cost_per_particle(), "polish": settings.polish,
            "polish_keep": settings.polish_keep, "polish_step": settings.polish_step,
            "polish_cost": settings.polish_cost(), "particles": settings.evaluations()}


def build(settings: FIPFSettings, limits: Limits, fps: float, body: posture.Body | None = None) -> Filter:
    """The factored IPF kernel for fixed settings; ``body`` (the subject's shape values and up
    rotation) is what the posture group needs (:mod:`.posture`)."""
    validate(settings)
    require(body is not None or not settings.posture,
            "the factored filter's posture group needs the body (the tracker gives it): "
            "build it with one, or with posture off")
    stages = _stages(settings, fps)
    m = settings.top_m
    all_std = rate_std(default_noise_rates(), fps) * settings.noise_scale
    n = settings.evaluations()
    k_filler = settings.rounds * len(stages)  # the filler's key, then the reach's arm draw's
    n_keys = k_filler + 1 + int(settings.reach)
    polish_step = SEARCH_STD * settings.polish_step

    def shapes_for(k: int) -> tuple:
        """(key index, shape) of each draw of a frame that starts from ``k`` kept particles."""
        return tuple((r * len(stages) + g, (k * len(st.offsets), len(st.noise_idx)))
                     for r in range(settings.rounds) for g, st in enumerate(stages)
                     if len(st.noise_idx)) + (((k_filler, (settings.filler, NUM_DOF)),)
                                              if settings.filler else ()) + (
            ((k_filler + 1, (1,)),) if settings.reach else ())

    def draws(rng_key: jax.Array) -> tuple:
        return _split_and_draw(rng_key, n_keys, shapes_for(m))

    def step(rng_key: jax.Array, state: FilterState, measure, drawn: tuple | None = None,
             shift: np.ndarray | None = None):
        kept = state.particles[top_distinct(state.particles, state.weights, m, shift)]  # (M, D)
        if shift is not None:  # moved as the whole set would be: the same sums
            kept += shift
        seen_p, seen_w = [], []
        shapes = shapes_for(len(kept))
        if drawn is None or tuple(a.shape for a in drawn[1]) != tuple(s for _, s in shapes):
            drawn = _split_and_draw(rng_key, n_keys, shapes)  # fewer than M distinct, or not ahead
        keys, zs = drawn
        z = dict(zip((i for i, _ in shapes), (np.asarray(a) for a in zs)))
        for r in range(settings.rounds):
            scale = settings.shrink ** r
            for g, stage in enumerate(stages):
                i = r * len(stages) + g
                cand = (posture.children(kept, stage.offsets * scale, body, limits.clip)
                        if stage.name == posture.NAME else _children(keys, i, kept, stage, scale, z.get(i)))
                if r == 0 and g == 0 and settings.filler:
                    extra = kept[np.arange(settings.filler) % m]
                    extra = extra + np.asarray(z[k_filler], np.float64) * all_std
                    cand = np.concatenate([cand, extra])
                cand = limits.clip(cand)
                w = np.asarray(measure(cand), float)
                seen_p.append(cand)
                seen_w.append(w)
                top = top_distinct(cand, w, m)
                kept = cand[top]
        last_p, last_w = seen_p[-1], seen_w[-1]
        if settings.reach:  # an arm over its whole range, from the best so far; clear gains kept
            arm = reach.pick(float(z[k_filler + 1][0]))
            pool_p, pool_w = reach.search(last_p[np.argmax(last_w)], arm, measure, limits.clip)
            keep = reach.gainers(pool_w, float(last_w.max()))
            pool_p, pool_w = pool_p[keep], pool_w[keep]
            seen_p.append(pool_p)
            seen_w.append(pool_w)
            last_p, last_w = np.concatenate([last_p, pool_p]), np.concatenate([last_w, pool_w])
        if settings.polish:  # the last degrees and millimetres: compass sweeps from the best
            pool_p, pool_w, _ = compass_search(last_p, last_w, lambda q: np.asarray(measure(q), float),
                                               limits.clip, polish_step, keep=settings.polish_keep,
                                               sweeps=settings.polish)
            seen_p.append(pool_p)
            seen_w.append(pool_w)
            last_p, last_w = np.concatenate([last_p, pool_p]), np.concatenate([last_w, pool_w])
        particles, weights = np.concatenate(seen_p), np.concatenate(seen_w)
        info = summarise(particles, weights, n)
        # the next frame starts from the last group's children (the M best are among them) and
        # the polish's last sweep
        return FilterState(last_p, last_w), info

    return Filter("fipf", init_state, step, n, _params(settings), settings.calls(), draws)
