"""Sagittal joint angles from 3-D points, and their curves over the gait cycle.

Every segment is projected on the sagittal plane of the straight part (walking direction x up) and
given the angle ``phi`` from the downward vertical, positive forward: ``phi(v) = atan2(v_fwd,
-v_up)``. Then, in degrees, per side:

- hip flexion = phi(thigh) - phi(trunk), thigh = hip -> knee, trunk = neck -> sacrum (the trunk
  pointing down); without a neck point the trunk is taken vertical (phi = 0).
- knee flexion = phi(thigh) - phi(shank), shank = knee -> ankle; 0 = straight, positive = flexed.
- ankle dorsiflexion = phi(foot) - 90 - phi(shank), foot = heel -> toe; 0 when the heel-toe line is
  perpendicular to the shank, positive = toes up. Needs real heel and toe points.

Angles are not filtered beyond the points' own low-pass. Curves are resampled per stride (heel
strike to the next heel strike of the same foot) onto 0, 1, ..., 100 % of the cycle.
"""
from __future__ import annotations

import numpy as np

CYCLE_SAMPLES = 101
JOINTS = ("hip", "knee", "ankle")


def sagittal_angle(v: np.ndarray) -> np.ndarray:
    """(..., 3) walking-frame vectors (forward, left, up) -> (...,) degrees from down, + forward."""
    return np.degrees(np.arctan2(v[..., 0], -v[..., 2]))


def _wrap(deg: np.ndarray) -> np.ndarray:
    return (deg + 180.0) % 360.0 - 180.0


def joint_angles(points: dict, side: str, *, has_heel: bool) -> tuple[dict, dict]:
    """Hip, knee and ankle angles of one side over a part.

    points : role -> (F, 3) walking-frame coordinates.  side : ``left``/``right``.
    has_heel : whether ``<side>_heel`` is a real heel (not the ankle standing in for it).
    Returns (angles, missing): joint -> (F,) degrees, and joint -> reason for those not computed.
    """
    p = {k[len(side) + 1:]: v for k, v in points.items() if k.startswith(side + "_")}
    angles, missing = {}, {}
    if "hip" in p and "knee" in p:
        thigh = sagittal_angle(p["knee"] - p["hip"])
        if "sacrum" in points and "neck" in points:
            trunk = sagittal_angle(points["sacrum"] - points["neck"])
        else:
            trunk = 0.0
        angles["hip"] = _wrap(thigh - trunk)
        if "ankle" in p:
            shank = sagittal_angle(p["ankle"] - p["knee"])
            angles["knee"] = _wrap(thigh - shank)
    for joint, need in (("hip", ("hip", "knee")), ("knee", ("hip", "knee", "ankle"))):
        if joint not in angles:
            lacking = [n for n in need if n not in p]
            missing[joint] = f"no {side} {' / '.join(lacking)} point"
    if has_heel and all(k in p for k in ("heel", "toe", "knee", "ankle")):
        foot = sagittal_angle(p["toe"] - p["heel"])
        shank = sagittal_angle(p["ankle"] - p["knee"])
        angles["ankle"] = _wrap(foot - 90.0 - shank)
    else:
        missing["ankle"] = (f"needs {side} heel, toe, knee and ankle points"
                            + ("" if has_heel else f" (no {side} heel point)"))
    return angles, missing


def cycle_curves(time: np.ndarray, angle: np.ndarray, strides: list) -> np.ndarray:
    """Resample ``angle`` (F,) over each (start_s, end_s) stride -> (S, 101) degrees."""
    out = np.empty((len(strides), CYCLE_SAMPLES))
    for k, (a, b) in enumerate(strides):
        out[k] = np.interp(np.linspace(a, b, CYCLE_SAMPLES), time, angle)
    return out
