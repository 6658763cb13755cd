"""A subject's proportions: the segment groups a shape fit moves, their anthropometric bounds, the
anatomical rule that places the hip joint centres inside the pelvis, and standing height.

The 45 shape parameters of :data:`ipf_jax.body.model.SHAPE_PARAM_NAMES` are moved in 15 left/right
symmetric **groups** (:data:`GROUPS`): 8 lengths (thigh, shank, foot, trunk, neck and head, upper
arm, forearm and hand), the sole-to-ankle height, 2 breadths (pelvis, shoulders), 4 girths
(torso, legs, arms, head and neck) and the shoe's girth (the foot's radii). Every
parameter of a group is multiplied by the group's factor, so a group keeps the template's internal
proportions (a longer foot is also a higher one). The head's radii are a girth of their own: when
they moved with the head's lengths, a fit that narrowed the head (the template's head reaches
lower than the renders' and is rounder) also lowered its top, and the tracker then lifted the whole
body by 2-3 cm to fill the head (docs/shape_fit.md). The foot's radii are apart from the
sole-to-ankle height for the same reason: a shoe is wider and taller than the bare template foot
by more than a limb's girth varies (-15..+100 %), and moving them with the ankle's vertical offsets
tied the foot's size to the ankle's height.

**Hip joint centres follow anatomy.** Silhouettes see the pelvis surface, not the joints in it:
the hip-region breadth ``B = hip_half_width + pelvis_r`` (half the pelvis capsule's breadth) is
what a fit can measure, and the hip joint centres are placed from it with Harrington et al.'s
(2007, J Biomech 40:595) regression of the hip-centre spacing on the pelvis width
``PW`` (inter-ASIS): ``hip_half_width = 0.33 PW + 7.3 mm``, where ``PW = 2 (B - t)`` and
``t = SOFT_TISSUE * H`` is the lateral margin from the ASIS to the skin, fixed at the template's
value (the template's 87.5 mm hip half-width at 1.75 m is this rule with ``t`` = 57 mm). So a
wider pelvis moves the hips apart by 0.66 of its half-breadth change, and the rest is soft tissue
(``pelvis_r = B - hip_half_width``). The pelvis capsule's lowest point, the crotch of a frontal
silhouette, lies ``crotch_depth`` below the hip joints (a trunk-group length): a broader or
softer pelvis widens the capsule without lowering the crotch, which would lift the hips.

**Bounds** (:data:`BOUNDS`): each parameter's ratio to standing height may lie within a fraction
of the template's ratio (Winter 2009 / Drillis & Contini, see ``presets/shape_default.json``):
lengths +-15 %, the foot's length -30 % .. +15 % (it places the centres of the foot's spheres,
whose radii grow with the shoe's girth, up to +100 %: at twice the template's toe radius the
tip stays within -15 % of the template's only with the centre 30 % nearer), breadths +-20 %,
hip joint spacing +-30 % (it follows the breadth, above, at 0.66
of its absolute change), girths +-30 %, and the sole-to-ankle height -15 % .. +150 % (the
template's is a barefoot ankle, 0.039 H = 68 mm at 1.75 m; shoes add 1-5 cm: the renders' shod
ankle centres are 97-124 mm over the floor). Why these: people's relative leg length differs by a few
per cent within one population and more between populations (relative leg length is studied as the
sitting-height ratio, reviewed by Bogin & Varela-Silva 2010, Int J Environ Res Public Health
7:1047; "brachyskelic" people sit at 49-51 % of stature), so +-15 % on each length
holds every adult we know of with room; breadths vary more than lengths (shoulder breadth with
muscle, pelvis breadth with sex), girths much more (body mass). The visible renders sit inside:
their leg lengths are +10 % (longlegs) to -12 % (heavy) of the template's ratio. A shape file
outside the bounds is refused (:func:`check_bounds`).

**Standing height** (:func:`stature`) is the chain floor -> ankle -> knee -> hip -> sacrum ->
neck -> head top of the model standing straight: sole-to-ankle height + shank + thigh +
``hip_down`` + trunk + neck + ``head_high`` + ``head_r``.
"""
from __future__ import annotations

import json
from pathlib import Path
from typing import NamedTuple

import numpy as np

from ..errors import IPFError, require
from .model import SHAPE_INDEX, SHAPE_PARAM_NAMES


class Group(NamedTuple):
    name: str
    kind: str  # "length", "foot", "breadth", "girth", "ankle" or "shoe" (a key of BOUNDS)
    params: tuple[str, ...]


GROUPS: tuple[Group, ...] = (
    Group("thigh", "length", ("thigh",)),
    Group("shank", "length", ("shank",)),
    # the foot's length places its spheres' centres; their radii grow with the shoe's girth, so
    # the foot may shorten further than a length (BOUNDS["foot"]) to keep its tip where it was
    Group("foot", "foot", ("heel_back", "toe_forward", "foot_back", "foot_tip")),
    # sole-to-ankle height: the foot's vertical offsets (shoes raise it; their size: foot_girth)
    Group("ankle", "ankle", ("heel_down", "toe_down", "foot_down", "foot_tip_down")),
    Group("trunk", "length", ("hip_down", "trunk", "crotch_depth", "trunk_low", "trunk_top_gap",
                              "shoulder_drop", "hip_forward")),
    Group("head", "length", ("neck", "head_forward", "head_low", "head_high")),
    Group("upper_arm", "length", ("upper_arm",)),
    Group("forearm", "length", ("forearm", "hand")),
    Group("pelvis", "breadth", ("hip_half_width", "pelvis_r")),  # via the hip rule (module doc)
    Group("shoulders", "breadth", ("shoulder_half_width",)),
    Group("torso_girth", "girth", ("trunk_r_low", "trunk_r_high", "trunk_half_width_low",
                                   "trunk_half_width_high")),
    Group("leg_girth", "girth", ("thigh_r0", "thigh_r1", "shank_r0", "shank_r1")),
    Group("arm_girth", "girth", ("upper_arm_r0", "upper_arm_r1", "forearm_r0", "forearm_r1",
                                 "hand_r0", "hand_r1")),
    # the head's and neck's radii apart from its lengths: a narrower or shorter-chinned head than
    # the template's must not lower the head's top (which would lift the whole body)
    Group("head_girth", "girth", ("head_r", "neck_r")),
    # the foot's radii apart from the sole-to-ankle height: a shoe is wider and taller than the
    # template's bare foot, by more than a limb's girth varies
    Group("foot_girth", "shoe", ("foot_r0", "foot_r1")),
)
GROUP_NAMES = tuple(g.name for g in GROUPS)
NUM_GROUPS = len(GROUPS)
assert sorted(p for g in GROUPS for p in g.params) == sorted(SHAPE_PARAM_NAMES), "every parameter in one group"

#: Allowed ratio to standing height, as (lower, upper) fractions of the template's ratio (module
#: doc); the template's ankle is a barefoot one (0.039 H), and shoes add 1-5 cm of sole and heel.
BOUNDS = {"length": (0.15, 0.15), "foot": (0.30, 0.15), "breadth": (0.20, 0.20),
          "girth": (0.30, 0.30), "ankle": (0.15, 1.50), "shoe": (0.15, 1.00)}
#: Where a shape fit starts and what its weak prior pulls towards, as each group's factor over
#: the template's ratio: the template's ankle is barefoot; everyday shoes add about 2.5 cm of
#: heel and sole (68 -> 92 mm at 1.75 m). Other groups: the template (1).
PRIOR_FACTORS = {"ankle": 1.70}
HIP_SPACING_BOUND = 0.30  # hip_half_width follows the pelvis breadth at 0.66 of its change
#: shape files written before ``crotch_depth`` (2026-12-05) reached 1.5-1.7x today's template
#: ratio below the hips (the pelvis capsule's axis was a fixed height over the hips, its radius
#: grew with the breadth); they stay valid
CROTCH_LEGACY_BOUND = 0.80

# Harrington et al. 2007: hip-centre half-spacing = 0.33 PW + 7.3 mm (PW = inter-ASIS width)
HARRINGTON_SLOPE = 0.33
HARRINGTON_OFFSET_M = 0.0073

_I = SHAPE_INDEX
_CHAIN = [_I[n] for n in ("shank", "thigh", "hip_down", "trunk", "neck", "head_high", "head_r")]


def sole_to_ankle(values: np.ndarray) -> np.ndarray:
    """(..., P) shape values -> (...) height (m) of the ankle centre over the floor, the model
    standing straight: the lower of the foot's two sphere bottoms below it."""
    v = np.asarray(values, np.float64)
    return np.maximum(v[..., _I["foot_down"]] + v[..., _I["foot_r0"]],
                      v[..., _I["foot_tip_down"]] + v[..., _I["foot_r1"]])


def stature(values: np.ndarray) -> np.ndarray:
    """(..., P) shape values -> (...) standing height (m) of the model standing straight."""
    v = np.asarray(values, np.float64)
    return sole_to_ankle(v) + v[..., _CHAIN].sum(-1)


def pelvis_breadth(values: np.ndarray) -> np.ndarray:
    """(..., P) -> (...) half-breadth B of the pelvis capsule (m): hip_half_width + pelvis_r."""
    v = np.asarray(values, np.float64)
    return v[..., _I["hip_half_width"]] + v[..., _I["pelvis_r"]]


def _template():
    """The default adult's values (read here, not through :mod:`.shape`, which imports this)."""
    doc = json.loads((Path(__file__).parent / "presets" / "shape_default.json").read_text())
    values = np.array([float(doc["params"][n]) for n in SHAPE_PARAM_NAMES])
    return values, float(stature(values))


_T_VALUES, _T_STATURE = _template()
TEMPLATE_RATIO = _T_VALUES / _T_STATURE  # (P,) every parameter over standing height
#: Lateral ASIS-to-skin margin over height, so that the rule gives the template's own hips.
SOFT_TISSUE = (pelvis_breadth(_T_VALUES)
               - (_T_VALUES[_I["hip_half_width"]] - HARRINGTON_OFFSET_M) / HARRINGTON_SLOPE / 2) / _T_STATURE


def hip_rule(values: np.ndarray) -> np.ndarray:
    """(..., P) values with hip_half_width and pelvis_r re-derived from the pelvis breadth B and
    standing height (the Harrington rule of the module doc); B is kept."""
    v = np.array(values, np.float64, copy=True)
    b = pelvis_breadth(v)
    pw = 2 * (b - SOFT_TISSUE * stature(v))
    hw = np.clip(HARRINGTON_SLOPE * pw + HARRINGTON_OFFSET_M, 0.25 * b, 0.85 * b)
    v[..., _I["hip_half_width"]] = hw
    v[..., _I["pelvis_r"]] = b - hw
    return v


def _param_bounds() -> tuple[np.ndarray, np.ndarray]:
    """(P,) lower and upper ratio-to-stature bounds per parameter."""
    lo, hi = np.zeros(len(SHAPE_PARAM_NAMES)), np.zeros(len(SHAPE_PARAM_NAMES))
    for g in GROUPS:
        for n in g.params:
            lo[_I[n]], hi[_I[n]] = BOUNDS[g.kind]
    lo[_I["hip_half_width"]] = hi[_I["hip_half_width"]] = HIP_SPACING_BOUND
    lo[_I["hip_forward"]] = 1.0  # 0 is an older shape file's (hips in the pelvis's plane)
    hi[_I["crotch_depth"]] = CROTCH_LEGACY_BOUND  # older files' deeper pelvis (module doc)
    return TEMPLATE_RATIO * (1 - lo), TEMPLATE_RATIO * (1 + hi)


RATIO_LOWER, RATIO_UPPER = _param_bounds()


def group_factors(values: np.ndarray) -> np.ndarray:
    """(..., P) -> (..., G) each group's ratio to stature over the template's (1 = template)."""
    v = np.asarray(values, np.float64)
    h = stature(v)[..., None]
    out = []
    for g in GROUPS:
        if g.name == "pelvis":
            out.append(pelvis_breadth(v) / h[..., 0] / pelvis_breadth(TEMPLATE_RATIO))
        else:
            i = _I[g.params[0]]
            out.append(v[..., i] / h[..., 0] / TEMPLATE_RATIO[i])
    return np.stack(out, -1)


def _scale_groups(values: np.ndarray, factors: np.ndarray) -> np.ndarray:
    """Multiply each group's parameters by (..., G) factors (pelvis: its breadth B, then the
    hip rule)."""
    v = np.array(values, np.float64, copy=True)
    for k, g in enumerate(GROUPS):
        idx = [_I[n] for n in g.params]
        v[..., idx] *= factors[..., k:k + 1]
    return hip_rule(v)


def group_bounds(bounds: dict | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(G,) lower and upper factors of every group: :data:`BOUNDS`, with ``bounds`` ({kind: (lower,
    upper) fractions}) replacing some kinds' (a fit of fewer views holds a group tighter)."""
    b = {**BOUNDS, **(bounds or {})}
    return (1 - np.array([b[g.kind][0] for g in GROUPS]), 1 + np.array([b[g.kind][1] for g in GROUPS]))


def build(reference: np.ndarray, log_factors: np.ndarray, height_m: float | None = None,
          iterations: int = 4, bounds: dict | None = None) -> np.ndarray:
    """Shape values from group log-factors, inside the bounds.

    reference : (P,) shape values the factors apply to (e.g. the template at the height found).
    log_factors : (..., G) natural logs of each group's factor (0 = the reference).
    height_m : standing height to keep (``dataset.json``'s ``height_m`` or ``--height``): the
        body is scaled uniformly to it; None = the height follows the lengths.
    bounds : kinds' bounds replacing :data:`BOUNDS`' (:func:`group_bounds`).
    Returns (..., P) values; each group's ratio to stature is clipped into its bounds.
    """
    theta = np.asarray(log_factors, np.float64)
    v = _scale_groups(np.broadcast_to(reference, theta.shape[:-1] + reference.shape[-1:]),
                      np.exp(theta))
    for _ in range(iterations):
        if height_m is not None:
            v = hip_rule(v * (height_m / stature(v))[..., None])
        f = group_factors(v)
        lo, hi = group_bounds(bounds)
        clipped = np.clip(f, lo + 1e-4, hi - 1e-4)
        if np.allclose(clipped, f, rtol=0, atol=1e-9) and height_m is None:
            break
        v = _scale_groups(v, clipped / f)
    v = within_bounds(v)
    if height_m is not None:
        v = hip_rule(v * (height_m / stature(v))[..., None])
    return v


def within_bounds(values: np.ndarray, iterations: int = 40) -> np.ndarray:
    """(..., P) values with every parameter's ratio to stature clipped into
    :data:`RATIO_LOWER`..:data:`RATIO_UPPER` (what :func:`check_bounds` asks of a shape file).

    Group factors (:func:`build`) are read off each group's first parameter, and the
    initialisation's proportion search lengthens some parameters alone
    (:meth:`~ipf_jax.body.shape.BodyShape.with_factors`), so a group's other parameters could end
    outside their own bounds: a fitted ``shape.json`` that ``--shape`` then refused. Clipping moves
    the stature, so it is repeated until nothing moves (a clipped length of the standing chain
    converges by about a third a round)."""
    v = np.array(values, np.float64, copy=True)
    for _ in range(iterations):
        h = stature(v)[..., None]
        clipped = np.clip(v, RATIO_LOWER * h, RATIO_UPPER * h)
        if np.array_equal(clipped, v):
            break
        v = clipped
    return v


def check_bounds(values: np.ndarray, path=None, tolerance: float = 0.005) -> None:
    """Raise IPFError naming the first parameter whose ratio to the standing height is outside
    :data:`RATIO_LOWER`..:data:`RATIO_UPPER` (widened by ``tolerance``, relative)."""
    v = np.asarray(values, np.float64)
    h = float(stature(v))
    require(np.isfinite(h) and h > 0, "the shape has no positive standing height", path)
    lo, hi = RATIO_LOWER * (1 - tolerance) * h, RATIO_UPPER * (1 + tolerance) * h
    for n in SHAPE_PARAM_NAMES:
        i = _I[n]
        if not lo[i] <= v[i] <= hi[i]:
            raise IPFError(f"shape parameter {n} = {v[i]:.4f} m is outside its anthropometric bounds "
                            f"{lo[i]:.4f}..{hi[i]:.4f} m for a body {h:.3f} m tall "
                            "(see ipf_jax.body.proportions)", path)

