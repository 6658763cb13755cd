"""The measures balance and fall-risk work uses, with reference ranges where a cited one exists.

The seed paper's purpose is detecting balance disorders in the elderly. The measures below are the
ones the gait literature links to falls: walking speed, cadence, stride-time, step-time and
step-length variability (SD and coefficient of variation, CV = 100 SD / mean), double support
(% of the gait cycle), step-width variability and left/right symmetry (Robinson's symmetry
index). Each comes with its count and, in :data:`REFERENCES`, what the literature says.

Only walking speed has a numeric cut point here that we could check in its source: the World
Falls Guidelines recommend < 0.8 m/s as the gait-speed criterion for increased fall risk
(Montero-Odasso et al. 2022); the other measures carry the direction of the association and its
source, and no invented range (``docs/gait.md`` lists the sources).

Variability needs strides: SD and CV are given from :data:`MIN_VARIABILITY_N` values up, with
their count, and a note when there are fewer than :data:`FEW_N` (one pass over a walkway or a
short clip gives few strides, and such SDs are rough).
"""
from __future__ import annotations

from typing import NamedTuple

MIN_VARIABILITY_N = 3
FEW_N = 10


class Reference(NamedTuple):
    """below / above : cut points (None = none); text : what the source says; source : citation."""

    below: float | None
    above: float | None
    text: str
    source: str


WFG = ("Montero-Odasso M, Van der Velde N, Martin FC, et al. World guidelines for falls "
       "prevention and management for older adults: a global initiative. Age Ageing 2022;"
       "51(9):afac205")
BRACH = ("Brach JS, Berlin JE, VanSwearingen JM, Newman AB, Studenski SA. Too much or too little "
         "step width variability is associated with a fall history in older persons who walk at "
         "or near normal gait speed. J NeuroEng Rehabil 2005;2:21")
VERGHESE = ("Verghese J, Holtzer R, Lipton RB, Wang C. Quantitative gait markers and incident "
            "fall risk in older adults. J Gerontol A Biol Sci Med Sci 2009;64A(8):896-901")
ROBINSON = ("Robinson RO, Herzog W, Nigg BM. Use of force platform variables to quantify the "
            "effects of chiropractic manipulation on gait symmetry. J Manipulative Physiol Ther "
            "1987;10(4):172-176")

#: Base name of a measure -> what its source says (keys as in :func:`measures`' output, without
#: the ``_sd_*`` / ``_cv_pct`` / ``_pct`` suffix).
REFERENCES = {
    "walking_speed": Reference(
        0.8, None, "below 0.8 m/s: increased fall risk (World Falls Guidelines gait-speed "
        "criterion for older adults)", WFG),
    "stride_time": Reference(
        None, None, "higher stride-time variability is associated with falling (as summarised "
        "in the source)", BRACH),
    "step_time": Reference(None, None, "step-time variability did not differ with fall history "
                           "in the source", BRACH),
    "step_length": Reference(None, None, "stride-length variability predicted falls; step-"
                             "length variability did not differ with fall history in Brach 2005",
                             VERGHESE),
    "double_support": Reference(None, None, "a longer double-support phase predicted falls",
                                VERGHESE),
    "step_width": Reference(None, None, "both too little and too much step-width variability "
                            "went with a fall history", BRACH),
    "symmetry": Reference(None, None, "0 = symmetric; positive = right larger (Robinson's "
                          "index); no reference range", ROBINSON),
}


def measures(params: dict, symmetry: dict, lab: dict, *, unobservable: dict) -> dict:
    """The fall-risk block of ``gait.json``.

    params, symmetry : from :func:`~.parameters.summarise`.  lab : from
    :func:`~.parameters.cadence_and_speed`.  unobservable : parameter -> why it is not measured.
    Returns name -> ``{"value", "unit", "n", "flag", "reference", "note"}`` (value None with a
    note when it cannot be given).
    """
    out = {}

    def put(name, value, unit, n, note="", ref_key=None):
        ref = REFERENCES.get(ref_key)
        flag = None
        if value is not None and ref is not None:
            if ref.below is not None and value < ref.below:
                flag = f"below {ref.below:g}"
            if ref.above is not None and value > ref.above:
                flag = f"above {ref.above:g}"
        out[name] = {"value": value, "unit": unit, "n": n, "flag": flag,
                     "reference": None if ref is None else ref._asdict(), "note": note}

    speed = lab.get("walking_speed_m_s")
    note = "pelvis travel between the first and last heel strike over that time"
    if speed is None:
        speed = params["walking_speed_m_s"]["all"]["mean"]
        note = "mean stride speed (treadmill or no pelvis travel)"
    put("walking_speed_m_s", speed, "m/s", lab.get("steps") or 0,
        "" if speed is not None else "no steps to measure", "walking_speed")
    if speed is not None:
        out["walking_speed_m_s"]["note"] = note
    put("cadence_steps_per_min", lab.get("cadence_steps_per_min"), "steps/min",
        lab.get("steps") or 0, "steps between the first and last heel strike over that time")
    for name, key, unit in (("stride_time", "stride_time_s", "s"),
                            ("step_time", "step_time_s", "s"),
                            ("step_length", "step_length_m", "m"),
                            ("step_width", "step_width_m", "m")):
        stat = params[key]["all"]
        n = stat["n"]
        sd_name, cv_name = f"{name}_sd_{unit}", f"{name}_cv_pct"
        if key in unobservable:
            put(sd_name, None, unit, 0, f"not observable: {unobservable[key]}", name)
            put(cv_name, None, "%", 0, f"not observable: {unobservable[key]}", name)
            continue
        few = f"from {n} values only: a rough estimate" if MIN_VARIABILITY_N <= n < FEW_N else ""
        ok = n >= MIN_VARIABILITY_N
        why = few if ok else f"needs {MIN_VARIABILITY_N} values, found {n}"
        put(sd_name, stat["sd"] if ok else None, unit, n, why, name)
        put(cv_name, stat["cv_pct"] if ok else None, "%", n, why, name)
    ds = params["double_support_pct"]["all"]
    put("double_support_pct", ds["mean"], "% of the gait cycle", ds["n"],
        "" if ds["mean"] is not None else "needs strides with the toe-offs of both feet",
        "double_support")
    for key in ("step_length_m", "step_time_s", "stance_s", "swing_s"):
        value = symmetry.get(key)
        if key in unobservable:
            value = None
        put(f"symmetry_{key.rsplit('_', 1)[0]}_pct", value, "%",
            min(params[key]["left"]["n"], params[key]["right"]["n"]),
            "" if value is not None else "needs the parameter on both sides", "symmetry")
    return out
