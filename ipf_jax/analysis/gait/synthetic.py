"""A procedural walk with known cadence, step length and events, for tests and demonstrations.

Everything is laid out along a path on the floor: the sacrum moves along it at constant speed;
each foot stands still on a footprint for the stance fraction of the stride, then swings to the
next footprint with a raised-cosine profile (zero velocity at both ends). Footprints alternate
left and right, half a stride apart, so the true step length is ``speed * stride_time / 2``.
The path is straight, or straight - U-turn - straight back (``turn=True``). The rest of the body
is placed rigidly around the sacrum and the feet; it only has to look plausible.

The generator's own "heel strike" is the instant the foot stops, which kinematic methods (Zeni)
see about 30 ms earlier because the foot decelerates smoothly here: compare intervals and
lengths with it, not absolute event times.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ...geometry.world import axis_vector
from .direction import horizontal_basis
from .trajectories import Trajectories, make_trajectories

FOOT = 0.20          # heel -> toe, m
HEEL_AHEAD = 0.25    # heel ahead of the sacrum at strike, as a fraction of the stride length


class WalkTruth(NamedTuple):
    """Ground truth of :func:`synthetic_walk`: step_length_m, stride_time_s, cadence, speed."""

    step_length_m: float
    stride_time_s: float
    cadence_steps_per_min: float
    speed_m_s: float


def synthetic_walk(*, duration_s: float = 6.0, fps: float = 50.0, speed: float = 1.2,
                   cadence: float = 108.0, stance: float = 0.62, up_axis: str = "+z",
                   heading_deg: float = 0.0, treadmill: bool = False, turn: bool = False,
                   noise_m: float = 0.0, rng: np.random.Generator | None = None,
                   t0: float = 0.0) -> tuple[Trajectories, WalkTruth]:
    """Generate a walk (T = duration_s * fps frames) and its truth.

    ``heading_deg`` turns the initial walking direction about the up axis; ``treadmill`` keeps
    the sacrum in place (footprints slide backwards with the belt); ``turn`` walks 40 % of the
    time out, turns on a 0.6 m radius, and walks back. ``noise_m`` adds Gaussian noise from
    ``rng`` (required when noise_m > 0). Times start at ``t0``.
    """
    t = t0 + np.arange(int(round(duration_s * fps))) / fps
    stride_t = 120.0 / cadence
    stride = speed * stride_t
    sac_s = speed * (t - t0)
    lateral = {"left": 0.09, "right": -0.09}
    arc, lift = {}, {}
    for side, phase in (("right", 0.0), ("left", 0.5)):
        n = np.floor((t - t0) / stride_t - phase)
        strike = t0 + (n + phase) * stride_t
        u = (t - strike) / stride_t
        footprint = speed * (strike - t0) + HEEL_AHEAD * stride
        swing = np.clip((u - stance) / (1.0 - stance), 0.0, 1.0)
        arc[side] = footprint + stride * 0.5 * (1.0 - np.cos(np.pi * swing))
        lift[side] = 0.12 * np.sin(np.pi * swing)
    if treadmill:
        for side in arc:
            arc[side] = arc[side] - sac_s
        sac_s = np.zeros_like(sac_s)
    place = _path(turn, speed * duration_s)
    bob = 0.01 * np.cos(4 * np.pi * (t - t0) / stride_t)
    pts = {"sacrum": place(sac_s, 0.02 * np.sin(2 * np.pi * (t - t0) / stride_t), 0.95 + bob)}
    for side in ("left", "right"):
        s, l, h = arc[side], lateral[side], 0.03 + lift[side]
        pts[f"{side}_heel"] = place(s, l, h)
        pts[f"{side}_toe"] = place(s + FOOT, l, 0.03 + 0.5 * lift[side])
        pts[f"{side}_ankle"] = place(s + 0.05, l, h + 0.07)
        hip_s = sac_s + 0.05
        pts[f"{side}_hip"] = place(hip_s, l, 0.90 + bob)
        pts[f"{side}_knee"] = place(0.5 * (hip_s + s) + 0.06, l, 0.5 * (0.9 + h + 0.07))
        pts[f"{side}_shoulder"] = place(sac_s, 1.9 * l, 1.45 + bob)
        pts[f"{side}_elbow"] = place(sac_s - 0.02, 2.0 * l, 1.15 + bob)
        pts[f"{side}_wrist"] = place(sac_s + 0.05, 2.0 * l, 0.90 + bob)
    pts["neck"] = place(sac_s + 0.03, np.zeros_like(t), 1.50 + bob)
    pts["head"] = place(sac_s + 0.03, np.zeros_like(t), 1.70 + bob)
    frame = _world_frame(up_axis, heading_deg)
    out = {k: v @ frame.T for k, v in pts.items()}
    if noise_m > 0:
        if rng is None:
            raise ValueError("noise_m > 0 needs an explicit rng (numpy Generator)")
        out = {k: v + rng.normal(0.0, noise_m, v.shape) for k, v in out.items()}
    traj = make_trajectories(t, out, up_axis=up_axis, source="synthetic", fps=fps)
    return traj, WalkTruth(stride / 2, stride_t, cadence, speed)


def _path(turn: bool, length: float):
    """Returns place(s, l, h) -> (F, 3) local (x, y, z-up) points at arc s, left offset l."""
    radius = 0.6
    s1 = 0.4 * length

    def place(s, l, h):
        s = np.asarray(s, dtype=float)
        l = np.broadcast_to(l, s.shape)
        h = np.broadcast_to(h, s.shape)
        if not turn:
            return np.stack([s, l, h], axis=1)
        theta = np.clip((s - s1) / radius, 0.0, np.pi)
        centre = np.array([s1, radius])
        on_arc = np.stack([centre[0] + radius * np.sin(theta), centre[1] - radius * np.cos(theta)],
                          axis=1)
        after = np.clip(s - s1 - np.pi * radius, 0.0, None)
        before = np.clip(s - s1, None, 0.0)
        tangent = np.stack([np.cos(theta), np.sin(theta)], axis=1)
        base = on_arc + (before + after)[:, None] * tangent
        normal = np.stack([-np.sin(theta), np.cos(theta)], axis=1)
        xy = base + l[:, None] * normal
        return np.stack([xy[:, 0], xy[:, 1], h], axis=1)

    return place


def _world_frame(up_axis: str, heading_deg: float) -> np.ndarray:
    """(3, 3) matrix taking local (forward, left, up) to world, forward turned by heading."""
    up = axis_vector(up_axis)
    a, left0 = horizontal_basis(up)
    c, s = np.cos(np.radians(heading_deg)), np.sin(np.radians(heading_deg))
    fwd = c * a + s * left0
    return np.stack([fwd, np.cross(up, fwd), up], axis=1)
