"""The up axis and the length unit of a walking trial, read from the body itself.

Files state these unreliably: a TRC has no up-axis field, C3D's ``POINT:Y_SCREEN`` is a viewing
hint (the Qualisys trial in ``gait_trials`` says ``-Z`` for a +Z-up lab), and a unit may be
missing. A walking person settles both: the pelvis is 0.5-1.1 m above the feet, straight up, while
its horizontal offset from the mean of the feet averages out over a step. So:

* **up axis**: the signed coordinate axis along the median of (pelvis - mean of the feet) over
  the frames where both exist, accepted when that component is at least :data:`UP_MARGIN` times
  each other component (a margin, not a best guess);
* **units**: the unit that puts that height in :data:`PELVIS_HEIGHT_M`; a stated unit that does
  not is an error (wrong ``Units`` field), not a silent rescale.
"""
from __future__ import annotations

import warnings

import numpy as np

from ...errors import IPFWarning

#: The vertical component must dominate each horizontal one by this factor.
UP_MARGIN = 2.0
#: Plausible height of the pelvis above the foot markers, metres (a child to a tall adult).
PELVIS_HEIGHT_M = (0.25, 1.6)
_TOP = ("sacrum", "pelvis")
_BOTTOM = ("left_heel", "right_heel", "left_toe", "right_toe", "left_ankle", "right_ankle")


def pelvis_over_feet(points: dict) -> np.ndarray | None:
    """(3,) median of pelvis minus mean foot position over the frames holding both, or None.

    points : role -> (T, 3) in any unit. The pelvis is the sacrum, the ``pelvis`` role or the
    midpoint of the hips; the feet are the heels, toes and ankles present.
    """
    top = next((points[r] for r in _TOP if r in points and np.isfinite(points[r]).any()), None)
    if top is None and "left_hip" in points and "right_hip" in points:
        top = 0.5 * (points["left_hip"] + points["right_hip"])
    feet = [points[r] for r in _BOTTOM if r in points]
    if top is None or not feet:
        return None
    stack = np.stack(feet)                                         # (K, T, 3)
    ok = np.all(np.isfinite(stack), axis=2)                        # (K, T)
    with np.errstate(invalid="ignore"):
        bottom = np.where(ok[..., None], stack, 0.0).sum(0) / ok.sum(0)[:, None]
    d = top - bottom
    good = np.all(np.isfinite(d), axis=1)
    if good.sum() < 5:
        return None
    return np.median(d[good], axis=0)


def infer_up(points: dict) -> tuple[str | None, str]:
    """The up axis (``+x`` ... ``-z``) the body shows, or None, and a sentence saying why."""
    d = pelvis_over_feet(points)
    if d is None:
        return None, "no frames with both a pelvis point and a foot point"
    order = np.argsort(-np.abs(d))
    i, j = int(order[0]), int(order[1])
    if abs(d[j]) > 0 and abs(d[i]) < UP_MARGIN * abs(d[j]):
        return None, (f"the pelvis is not clearly above the feet along one axis (median offset "
                      f"{_fmt(d)})")
    axis = ("+" if d[i] > 0 else "-") + "xyz"[i]
    return axis, f"the pelvis is {abs(d[i]):.3g} units above the feet along {axis}"


def warn_if_contradicted(points: dict, up: str, name: str) -> None:
    """One warning when the body shows another up axis than the one given (``--up``): with a wrong
    one every step length and speed comes out wrong without an error."""
    shown, why = infer_up(points)
    if shown is not None and shown != up:
        warnings.warn(IPFWarning(f"{name}: --up {up}, but {why}: is the up axis {shown}?"), stacklevel=3)


def pelvis_height(points: dict, up: np.ndarray) -> float | None:
    """Median height of the pelvis above the feet along ``up`` (units of ``points``), or None."""
    d = pelvis_over_feet(points)
    return None if d is None else float(d @ up)


def infer_unit(height: float, scales: dict) -> str | None:
    """The unit of ``scales`` (name -> metres per unit) that makes ``height`` a pelvis height."""
    for name, scale in scales.items():
        if PELVIS_HEIGHT_M[0] <= height * scale <= PELVIS_HEIGHT_M[1]:
            return name
    return None


def _fmt(v: np.ndarray) -> str:
    return "(" + ", ".join(f"{x:.3g}" for x in v) + ")"
