"""Figures of an evaluation, after the paper's figure 7.

``displacement.png``: longitudinal displacement of a knee and an ankle against time, the estimate
plain with its samples marked, the reference dotted at its own (often higher) rate, one panel per
joint. "Longitudinal" is the walking direction, taken as the first principal direction of the
reference's mean joint position over time (the paper used the camera's x axis, which is what that
direction was in its set-up); displacements start from the reference's first position.

Figures use a bare :class:`matplotlib.figure.Figure` with the Agg canvas: no pyplot state.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from ...data.runfiles import JointsTable
from .metrics import Evaluation

#: Joints drawn by default, in order of preference per panel (the paper shows the right side).
PANELS = (("right_knee", "left_knee"), ("right_ankle", "left_ankle"))


def walking_direction(points: np.ndarray) -> np.ndarray:
    """(3,) unit direction of travel of (T, J, 3) points (first principal axis, first -> last)."""
    centre = np.nanmean(points, axis=1)  # (T, 3)
    centre = centre[np.isfinite(centre).all(1)]
    if len(centre) < 2:
        return np.array([1.0, 0.0, 0.0])
    _, s, vt = np.linalg.svd(centre - centre.mean(0), full_matrices=False)
    if s[0] < 1e-6:  # standing still: no direction to find
        return np.array([1.0, 0.0, 0.0])
    d = vt[0]
    return d if d @ (centre[-1] - centre[0]) >= 0 else -d


def panel_joints(names, wanted=None) -> list[str]:
    """The joints to draw: ``wanted`` where present, else a knee and an ankle when there are any."""
    if wanted:
        return [j for j in wanted if j in names]
    out = []
    for choices in PANELS:
        out += [j for j in choices if j in names][:1]
    return out


def plot_displacement(ev: Evaluation, truth: JointsTable, path: str | Path, *,
                      joints=None) -> Path | None:
    """Write the figure-7 style plot to ``path``; None when no knee/ankle (or ``joints``) to draw."""
    names = panel_joints(ev.names, joints)
    if not names:
        return None
    t_idx = [truth.names.index(n) for n in ev.scored]
    direction = walking_direction(truth.points[:, t_idx])
    origin = np.nanmean(truth.points[:, t_idx], axis=1)
    origin = origin[np.isfinite(origin).all(1)][0] @ direction
    lo, hi = ev.time_s[ev.inside].min(), ev.time_s[ev.inside].max()
    margin = 0.05 * max(hi - lo, 1e-3)
    keep = (truth.time_s >= lo - margin) & (truth.time_s <= hi + margin)
    fig = Figure(figsize=(8, 2.8 * len(names)), dpi=100)
    FigureCanvasAgg(fig)
    for k, name in enumerate(names):
        ax = fig.add_subplot(len(names), 1, k + 1)
        ref = truth.points[keep, truth.names.index(name)] @ direction - origin
        est = ev.estimate[:, ev.names.index(name)] @ direction - origin
        ax.plot(truth.time_s[keep], ref, ":", color="k", lw=1.6, label="truth")
        ax.plot(ev.time_s, est, "-o", color="tab:blue", ms=3, lw=1.2, label="estimate")
        ax.set_ylabel(f"{name.replace('_', ' ')} x (m)")
        ax.grid(alpha=0.3)
        err = ev.per_joint_m.get(name)
        ax.set_title(f"{name.replace('_', ' ')}: mean 3D error "
                     + (f"{1000 * err:.1f} mm" if err is not None else "n/a"), fontsize=10)
        if k == 0:
            ax.legend(fontsize=8, loc="upper left")
    ax.set_xlabel("time (s)")
    fig.suptitle("Longitudinal displacement (walking direction), estimate vs truth"
                 + (" after rigid alignment" if ev.align["mode"] == "rigid" else ""), fontsize=11)
    fig.tight_layout()
    fig.savefig(path)
    return Path(path)
