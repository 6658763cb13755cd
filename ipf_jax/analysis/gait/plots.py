"""PNG figures of a gait analysis, in the spirit of the paper's figures 7 and 8.

``displacement.png``: longitudinal displacement of both ankles along the walking direction against
time (right plain, left dotted, as in figure 8), heel strikes and toe-offs marked on the curves.
``angles.png``: sagittal hip, knee (and ankle) angles over the gait cycle, each stride thin and
the mean thick, left and right in their own colours. ``variability.png``: what the fall-risk
measures summarise, stride by stride: stride time, step length and step width (when the cameras
measure it) against time, left and right, with the mean and +-1 SD band and the CV in the title.

Figures are drawn on a bare :class:`matplotlib.figure.Figure` with the Agg canvas, so no global
pyplot state or display is involved.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from .angles import JOINTS
from .parameters import SIDES

COLOURS = {"left": "tab:red", "right": "tab:blue"}
STYLES = {"left": ":", "right": "-"}
JOINT_LABELS = {"hip": "hip flexion (deg)", "knee": "knee flexion (deg)",
                "ankle": "ankle dorsiflexion (deg)"}


def plot_displacement(result, path: str | Path) -> Path:
    """Ankle (or heel stand-in) forward displacement vs time with events; writes ``path``."""
    fig = Figure(figsize=(9, 4.5), dpi=100)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(1, 1, 1)
    for part in result.parts:
        origin = part.coords["sacrum"][0, 0]
        for side in SIDES:
            role = f"{side}_ankle" if f"{side}_ankle" in part.coords else f"{side}_heel"
            x = part.coords[role][:, 0] - origin
            label = f"{side} {role.split('_')[1]}" if part.index == 0 else None
            ax.plot(part.time, x, STYLES[side], color=COLOURS[side], label=label)
            ev = part.events[side]
            for times, marker, name in ((ev.heel_strike, "v", "heel strike"),
                                        (ev.toe_off, "^", "toe-off")):
                if len(times):
                    ax.plot(times, np.interp(times, part.time, x), marker, color=COLOURS[side],
                            mfc=COLOURS[side] if marker == "v" else "white", ms=8,
                            label=f"{side} {name}" if part.index == 0 else None)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("displacement along walking direction (m)")
    ax.set_title(f"Longitudinal displacement of the ankles ({result.method} events)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, ncol=3, loc="upper left")
    fig.tight_layout()
    fig.savefig(path)
    return Path(path)


def plot_angles(result, path: str | Path) -> Path | None:
    """Joint angle curves over 0-100 % of the cycle; writes ``path`` (None if no curve)."""
    joints = [j for j in JOINTS if any(result.curves[s].get(j, np.empty((0, 0))).size
                                       for s in SIDES)]
    if not joints:
        return None
    fig = Figure(figsize=(6, 2.6 * len(joints)), dpi=100)
    FigureCanvasAgg(fig)
    pct = np.linspace(0, 100, 101)
    for k, joint in enumerate(joints):
        ax = fig.add_subplot(len(joints), 1, k + 1)
        for side in SIDES:
            cycles = result.curves[side].get(joint)
            if cycles is None or not len(cycles):
                continue
            for c in cycles:
                ax.plot(pct, c, color=COLOURS[side], lw=0.7, alpha=0.4)
            ax.plot(pct, cycles.mean(axis=0), STYLES[side], color=COLOURS[side], lw=2,
                    label=f"{side} (n={len(cycles)})")
        ax.set_ylabel(JOINT_LABELS[joint])
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    ax.set_xlabel("gait cycle (% from heel strike)")
    fig.tight_layout()
    fig.savefig(path)
    return Path(path)


def plot_variability(result, path: str | Path) -> Path | None:
    """Stride times, step lengths and step widths over time with mean +- SD; None if no rows."""
    panels = [("stride_time_s", "stride time (s)", result.strides),
              ("step_length_m", "step length (m)", result.steps)]
    if "step_width_m" not in result.unobservable:
        panels.append(("step_width_m", "step width (m)", result.steps))
    panels = [p for p in panels if any(np.isfinite(getattr(r, p[0])) for r in p[2])]
    if not panels:
        return None
    fig = Figure(figsize=(7, 2.4 * len(panels)), dpi=100)
    FigureCanvasAgg(fig)
    for k, (field, label, rows) in enumerate(panels):
        ax = fig.add_subplot(len(panels), 1, k + 1)
        values = np.array([getattr(r, field) for r in rows], dtype=float)
        ok = np.isfinite(values)
        mean, sd = values[ok].mean(), values[ok].std(ddof=1) if ok.sum() > 1 else 0.0
        ax.axhspan(mean - sd, mean + sd, color="0.85")
        ax.axhline(mean, color="0.4", lw=1)
        for side in SIDES:
            pick = [(r.end_s, getattr(r, field)) for r in rows
                    if r.side == side and np.isfinite(getattr(r, field))]
            if pick:
                t, v = zip(*pick)
                ax.plot(t, v, "o" + STYLES[side], color=COLOURS[side], label=side)
        cv = f", CV {100 * sd / abs(mean):.1f} %" if ok.sum() > 1 and mean else ""
        ax.set_title(f"{label}: mean {mean:.3f}, SD {sd:.3f}{cv} (n={int(ok.sum())})",
                     fontsize=9)
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    ax.set_xlabel("time at the end of the step / stride (s)")
    fig.tight_layout()
    fig.savefig(path)
    return Path(path)
