"""Spatio-temporal gait parameters from events and foot positions, the way gait labs compute them.

Definitions (``docs/gait.md`` has the full table). A *step* runs from a heel strike of one foot to
the next heel strike of the other foot and is named after the foot that strikes at its end. A
*stride* (gait cycle) runs between two heel strikes of the same foot.

- step length: forward distance between the two heels at their strikes (overground: the
  striking heel minus where the other heel struck, as on a walkway; treadmill: the two heels at the
  moment of the strike, since the belt carries the footprints away). Step width: lateral distance
  between the two heels at their strikes.
- stride length: forward displacement of the heel between its two strikes (treadmill: sum of the
  two step lengths). Stride speed = stride length / stride time.
- stance = heel strike to toe-off, swing = toe-off to the next heel strike. Per stride the initial
  double support runs from the heel strike to the other foot's toe-off, the terminal one from the
  other foot's heel strike to this foot's toe-off; single support is the other foot's swing.
  Per step, double support is the time from the step's start to the stepping foot's toe-off.
- **cadence** (:func:`cadence_and_speed`) = steps counted between the first and the last heel
  strike of each straight part, over the time between them (60 x steps / s), summed over the
  parts; an interval between two strikes of the same foot counts as two steps (the other foot's
  strike was missed). Not a mean of per-step cadences, which short spurious steps inflate.
- **walking speed** overground = distance the pelvis travels between the first and last heel
  strike of each part over that time (as a walkway measures it); on a treadmill the mean stride
  speed.
- symmetry index (Robinson et al. 1987): 100 * (right - left) / (0.5 * (right + left)), in %.

**Physiological bounds** (:data:`STEP_BOUNDS`, :data:`STRIDE_BOUNDS`): a step or stride outside
them is rejected (listed in ``rejected`` with the reason) and takes no part in any statistic or in
cadence: step time 0.3-2.5 s (24-200 steps/min; faster is running), step length -0.5-1.5 m (a short or backward
step happens in step-to gait; longer than 1.5 m is not walking), step width 0-0.6 m; stride time
0.5-5 s, stance 30-95 % of the stride, double support not negative (a flight phase: running,
or wrong events). Before that, a heel strike closer than 0.3 s to the other foot's is dropped
(:func:`drop_close_strikes`): the one nearer an end of the part, where extrema are least reliable.
"""
from __future__ import annotations

from itertools import pairwise
from typing import NamedTuple

import numpy as np

SIDES = ("left", "right")
MIN_STEP_S = 0.3
#: field -> (low, high), inclusive; NaN values (unknown) are not judged.
STEP_BOUNDS = {"step_time_s": (MIN_STEP_S, 2.5), "step_length_m": (-0.5, 1.5),
               "step_width_m": (0.0, 0.6)}
STRIDE_BOUNDS = {"stride_time_s": (0.5, 5.0), "stance_pct": (30.0, 95.0),
                 "double_support_s": (0.0, np.inf)}


class Step(NamedTuple):
    """One step (seconds, metres); ``side`` is the foot striking at ``end_s``. NaN = unknown."""

    part: int
    side: str
    start_s: float
    end_s: float
    step_time_s: float
    step_length_m: float
    step_width_m: float
    toe_off_s: float
    double_support_s: float
    single_support_s: float


class Stride(NamedTuple):
    """One gait cycle of ``side`` from ``start_s`` to ``end_s``. NaN = unknown (event missing)."""

    part: int
    side: str
    start_s: float
    end_s: float
    stride_time_s: float
    stride_length_m: float
    walking_speed_m_s: float
    stance_s: float
    swing_s: float
    double_support_s: float
    single_support_s: float


class Rejected(NamedTuple):
    """A step or stride left out of the statistics. kind : ``step``/``stride``/``heel_strike``."""

    kind: str
    part: int
    side: str
    start_s: float
    end_s: float
    reason: str


#: Summary name (unit in the suffix) -> (row table, row field); ``_pct`` fields are % of the stride
#: time and ``cadence`` is 60 / step time (per side; ``all`` is replaced by the lab cadence).
SUMMARY = {
    "step_length_m": ("steps", "step_length_m"),
    "step_width_m": ("steps", "step_width_m"),
    "step_time_s": ("steps", "step_time_s"),
    "cadence_steps_per_min": ("steps", "cadence"),
    "stride_length_m": ("strides", "stride_length_m"),
    "stride_time_s": ("strides", "stride_time_s"),
    "walking_speed_m_s": ("strides", "walking_speed_m_s"),
    "stance_s": ("strides", "stance_s"),
    "stance_pct": ("strides", "stance_pct"),
    "swing_s": ("strides", "swing_s"),
    "swing_pct": ("strides", "swing_pct"),
    "single_support_s": ("strides", "single_support_s"),
    "single_support_pct": ("strides", "single_support_pct"),
    "double_support_s": ("strides", "double_support_s"),
    "double_support_pct": ("strides", "double_support_pct"),
}
SYMMETRY = ("step_length_m", "step_time_s", "stance_s", "swing_s", "single_support_s")


def drop_close_strikes(events: dict, start: float, end: float) -> tuple[dict, list]:
    """Drop heel strikes closer than :data:`MIN_STEP_S` to the other foot's strike.

    events : side -> FootEvents of one part spanning ``start``-``end`` s. Of two strikes too close,
    the one nearer an end of the part goes. Returns (events, rejected rows).
    """
    strikes = sorted((t, s) for s in SIDES for t in events[s].heel_strike)
    drop = set()
    for (t0, s0), (t1, s1) in pairwise(strikes):
        if s0 != s1 and t1 - t0 < MIN_STEP_S and (t0, s0) not in drop:
            edge0, edge1 = min(t0 - start, end - t0), min(t1 - start, end - t1)
            drop.add((t1, s1) if edge1 <= edge0 else (t0, s0))
    rejected = [Rejected("heel_strike", -1, s, t, t, f"within {MIN_STEP_S} s of the other "
                         "foot's heel strike (the shortest step accepted); the one nearer an end "
                         "of the part is dropped") for t, s in sorted(drop)]
    out = {s: events[s]._replace(heel_strike=np.array(
        [t for t in events[s].heel_strike if (t, s) not in drop])) for s in SIDES}
    return out, rejected


def steps_and_strides(part: int, time: np.ndarray, heels: dict, events: dict, *,
                      mode: str) -> tuple[list, list]:
    """Steps and strides of one straight part.

    time : (F,) s.  heels : side -> (F, 3) heel (or stand-in) in walking coordinates (forward,
    left, up).  events : side -> :class:`~ipf_jax.analysis.gait.events.FootEvents`.
    mode : ``overground`` or ``treadmill`` (changes the length definitions, see module docs).
    """
    def heel_at(side, t):
        return np.array([np.interp(t, time, heels[side][:, c]) for c in range(3)])

    strikes = sorted((t, s) for s in SIDES for t in events[s].heel_strike)
    steps = []
    for (t0, s0), (t1, s1) in pairwise(strikes):
        if s0 == s1:  # the other foot's strike was not found: no step to measure
            continue
        p1 = heel_at(s1, t1)
        p0 = heel_at(s0, t1) if mode == "treadmill" else heel_at(s0, t0)
        width = abs(p1[1] - heel_at(s0, t0)[1])
        to = _first_between(events[s1].toe_off, t0, t1)
        steps.append(Step(part, s1, t0, t1, t1 - t0, p1[0] - p0[0], width, to, to - t0, t1 - to))
    strides = []
    for side in SIDES:
        other = "right" if side == "left" else "left"
        hs = events[side].heel_strike
        for ta, tb in pairwise(hs):
            if mode == "treadmill":
                inside = [s.step_length_m for s in steps if ta < s.end_s <= tb]
                length = sum(inside) if len(inside) == 2 else np.nan
            else:
                length = heel_at(side, tb)[0] - heel_at(side, ta)[0]
            to = _first_between(events[side].toe_off, ta, tb)
            to_c = _first_between(events[other].toe_off, ta, to)
            hs_c = _first_between(events[other].heel_strike, to_c, to)
            ds = (to_c - ta) + (to - hs_c)
            strides.append(Stride(part, side, ta, tb, tb - ta, length, length / (tb - ta),
                                  to - ta, tb - to, ds, hs_c - to_c))
    return steps, strides


def apply_bounds(steps: list, strides: list, *, unobservable: tuple = ()) -> tuple[list, list,
                                                                                   list]:
    """Split rows into kept and rejected by :data:`STEP_BOUNDS` / :data:`STRIDE_BOUNDS`.

    unobservable : step fields not measured (e.g. ``step_width_m`` with one camera); they are
    neither judged nor kept (set to NaN). Returns (steps, strides, rejected).
    """
    kept_steps, kept_strides, rejected = [], [], []
    for s in steps:
        if unobservable:
            s = s._replace(**{f: np.nan for f in unobservable if f in Step._fields})
        why = _outside(s, STEP_BOUNDS)
        if why:
            rejected.append(Rejected("step", s.part, s.side, s.start_s, s.end_s, why))
        else:
            kept_steps.append(s)
    for s in strides:
        values = s._asdict()
        values["stance_pct"] = 100.0 * s.stance_s / s.stride_time_s
        why = _outside(values, STRIDE_BOUNDS)
        if why:
            rejected.append(Rejected("stride", s.part, s.side, s.start_s, s.end_s, why))
        else:
            kept_strides.append(s)
    return kept_steps, kept_strides, rejected


def cadence_and_speed(parts: list, rejected: list) -> dict:
    """Lab cadence and walking speed over the parts (see module docs).

    parts : (index, mode, strikes, pelvis_at) per part: ``strikes`` sorted (time, side) heel
    strikes, ``pelvis_at(t)`` -> forward pelvis position (m). Intervals overlapping a rejected
    step or stride are left out. Returns ``{"cadence_steps_per_min", "steps", "time_s",
    "walking_speed_m_s", "distance_m"}`` (values None when there is nothing to measure).
    """
    bad = [(r.part, r.start_s, r.end_s) for r in rejected if r.kind in ("step", "stride")]
    steps, time, dist = 0, 0.0, 0.0
    overground = True
    for index, mode, strikes, pelvis_at in parts:
        overground &= mode == "overground"
        for (t0, s0), (t1, s1) in pairwise(strikes):
            if any(p == index and a <= t0 + 1e-9 and t1 <= b + 1e-9 for p, a, b in bad):
                continue
            n = 1 if s0 != s1 else 2
            if n == 2 and not (STRIDE_BOUNDS["stride_time_s"][0] <= t1 - t0
                               <= STRIDE_BOUNDS["stride_time_s"][1]):
                continue
            steps += n
            time += t1 - t0
            dist += pelvis_at(t1) - pelvis_at(t0)
    out = {"steps": steps, "time_s": _num(time) if time else None,
           "cadence_steps_per_min": _num(60.0 * steps / time) if time else None,
           "distance_m": _num(dist) if time and overground else None,
           "walking_speed_m_s": _num(dist / time) if time and overground else None}
    return out


def summarise(steps: list, strides: list) -> tuple[dict, dict]:
    """Mean, SD, CV and count per side and overall, plus symmetry indices.

    Returns (parameters, symmetry): ``{name: {"left"|"right"|"all": {"mean", "sd", "cv_pct",
    "n"}}}`` with ``None`` for statistics that need more values (SD and CV need n >= 2);
    ``{name: percent or None}``.
    """
    values = _value_tables(steps, strides)
    params = {}
    for name in SUMMARY:
        per = {}
        for side in (*SIDES, "all"):
            v = np.array([x for s, x in values[name] if side in ("all", s) and np.isfinite(x)])
            mean = float(v.mean()) if v.size else None
            sd = float(v.std(ddof=1)) if v.size > 1 else None
            cv = 100.0 * sd / abs(mean) if sd is not None and mean else None
            per[side] = {"mean": _num(mean), "sd": _num(sd), "cv_pct": _num(cv),
                         "n": int(v.size)}
        params[name] = per
    symmetry = {}
    for name in SYMMETRY:
        r, l_ = params[name]["right"]["mean"], params[name]["left"]["mean"]
        ok = r is not None and l_ is not None and (r + l_) != 0
        symmetry[name] = _num(100.0 * (r - l_) / (0.5 * (r + l_))) if ok else None
    return params, symmetry


def missing_reasons(params: dict, symmetry: dict, *, counts: dict, has_toe: dict) -> dict:
    """Why each parameter lacks a side (or symmetry index), e.g. for ``gait.json`` ``missing``.

    counts : side -> (heel strikes, toe-offs) found.  has_toe : side -> bool.
    """
    def why(name, side):
        n_hs, n_to = counts[side]
        table = SUMMARY[name][0]
        if table == "steps":
            base = "needs a heel strike of each foot in a row"
        else:
            base = "needs two heel strikes of the same foot in one straight part"
        if table == "strides" and any(k in name for k in ("stance", "swing", "support")):
            if not has_toe[side]:
                return f"no {side} toe point, so no toe-offs"
            base += " with the toe-offs of both feet between them"
        return f"{base}; found {n_hs} {side} heel strikes and {n_to} {side} toe-offs"

    out = {}
    for name, per in params.items():
        for side in SIDES:
            if per[side]["n"] == 0:
                out[f"{name}.{side}"] = why(name, side)
    for name, value in symmetry.items():
        if value is None:
            out[f"symmetry_index_pct.{name}"] = "needs the parameter on both sides"
    return out


def _outside(row, bounds: dict) -> str:
    get = row.get if isinstance(row, dict) else (lambda k: getattr(row, k))
    for field, (lo, hi) in bounds.items():
        v = get(field)
        if v is not None and np.isfinite(v) and not (lo <= v <= hi):
            return f"{field} {v:.3g} outside the physiological range [{lo:g}, {hi:g}]"
    return ""


def _value_tables(steps: list, strides: list) -> dict:
    """Summary name -> [(side, value)] from the step and stride rows."""
    rows = {name: [] for name in SUMMARY}
    for s in steps:
        for name, (table, field) in SUMMARY.items():
            if table == "steps":
                v = 60.0 / s.step_time_s if field == "cadence" else getattr(s, field)
                rows[name].append((s.side, v))
    for s in strides:
        for name, (table, field) in SUMMARY.items():
            if table != "strides":
                continue
            if field.endswith("_pct"):
                v = 100.0 * getattr(s, field[:-4] + "_s") / s.stride_time_s
            else:
                v = getattr(s, field)
            rows[name].append((s.side, v))
    return rows


def _first_between(times: np.ndarray, a: float, b: float) -> float:
    """First of ``times`` strictly between ``a`` and ``b`` (NaN when none, or a/b unknown)."""
    if not (np.isfinite(a) and np.isfinite(b)):
        return np.nan
    inside = [t for t in times if a < t < b]
    return float(inside[0]) if inside else np.nan


def _num(x: float | None) -> float | None:
    return None if x is None or not np.isfinite(x) else float(round(float(x), 6))
