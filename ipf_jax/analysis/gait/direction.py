"""Walking direction, and the straight parts of a trial that can be analysed with one direction.

Overground: the sacrum's horizontal velocity, averaged over one second (about a stride, so the
side-to-side sway cancels), gives the heading. A part is a run of frames where the sacrum moves
faster than 0.15 m/s and the heading stays within 20 degrees of the heading where the part began;
turns and stops therefore end a part, and parts shorter than 0.8 s are skipped with a note. The
direction of a part is its net horizontal displacement.

Overground or treadmill is decided first, from the data with a margin (:mod:`.mode`). A clip
shorter than a straight part whose pelvis moves is analysed as one overground part, with a note.

Treadmill: the direction is the principal axis of the feet's horizontal motion relative to the
sacrum, signed so that the toes point forward (toe ahead of heel, or of ankle).

Neither: the trial has no walking, and :class:`IPFError` says so.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ...errors import IPFError
from .filtering import true_runs
from .mode import decide as decide_mode
from .mode import smoothed_velocity

MIN_SPEED = 0.15          # m/s: slower than this the sacrum is standing (or on a treadmill)
MAX_HEADING_DEV_DEG = 20.0
MIN_PART_S = 0.8
MIN_FOOT_EXCURSION = 0.15  # m: feet moving less than this relative to the sacrum are not walking
_SMOOTH_S = 1.0


class Heading(NamedTuple):
    """Orthonormal walking frame. forward, left, up : (3,) unit vectors (left = up x forward)."""

    forward: np.ndarray
    left: np.ndarray
    up: np.ndarray
    mode: str  # "overground" or "treadmill"


class Part(NamedTuple):
    """Frames ``start:stop`` of a data segment walked in one direction; distance_m of sacrum."""

    start: int
    stop: int
    heading: Heading
    distance_m: float


def make_heading(forward: np.ndarray, up: np.ndarray, mode: str) -> Heading:
    """Walking frame from any non-vertical ``forward`` (made horizontal) and ``up`` (3,)."""
    up = np.asarray(up, dtype=float) / np.linalg.norm(up)
    f = np.asarray(forward, dtype=float)
    f = f - (f @ up) * up
    f = f / np.linalg.norm(f)
    return Heading(f, np.cross(up, f), up, mode)


def to_walking(x: np.ndarray, heading: Heading) -> np.ndarray:
    """(..., 3) points -> (..., 3) coordinates (forward, left, up) in the walking frame."""
    basis = np.stack([heading.forward, heading.left, heading.up])  # (3, 3)
    return np.asarray(x) @ basis.T


def straight_parts(time: np.ndarray, sacrum: np.ndarray, feet: dict, up: np.ndarray, *,
                   source: str = "") -> tuple[list, list]:
    """Split one gap-free data segment into straight walking parts.

    time : (F,) s.  sacrum : (F, 3) m.  feet : {"left"/"right": (heel_or_ankle (F, 3),
    toe (F, 3) or None)}.  up : (3,). Returns (parts, notes). Overground or treadmill is decided
    first (:mod:`.mode`). Raises :class:`IPFError` when there is no walking at all or no part is
    long enough.
    """
    fps = (len(time) - 1) / (time[-1] - time[0])
    e1, e2 = horizontal_basis(up)
    path = np.stack([sacrum @ e1, sacrum @ e2], axis=1)               # (F, 2)
    vel = smoothed_velocity(time, path, _SMOOTH_S)
    speed = np.linalg.norm(vel, axis=1)
    excursion = _foot_excursion(sacrum, feet, e1, e2)
    travel = float(np.linalg.norm(path[-1] - path[0]))
    if excursion < MIN_FOOT_EXCURSION:
        raise IPFError(f"no walking found: between {time[0]:.2f} and {time[-1]:.2f} s the feet "
                       f"move at most {excursion:.2f} m relative to the sacrum (walking needs "
                       f"{MIN_FOOT_EXCURSION} m) and the sacrum travels {travel:.2f} m", source)
    heels = [np.stack([h @ e1, h @ e2], axis=1) for h, _ in feet.values()]
    mode = decide_mode(time, path, heels)
    if mode.mode == "treadmill":
        heading = _treadmill_heading(sacrum, feet, e1, e2, up, source)
        return [Part(0, len(time), heading, travel)], [
            mode.note + "; direction from the feet's fore-aft motion"]
    min_frames = max(3, int(np.ceil(MIN_PART_S * fps)))
    notes = [mode.note]
    runs = [(a, b) for a, b in true_runs(speed > MIN_SPEED) if b - a >= min_frames]
    if not runs:
        # a clip shorter than a straight part, with the pelvis moving: one part, said so
        disp = path[-1] - path[0]
        if len(time) < 4 or np.linalg.norm(disp) <= 0:
            raise IPFError(f"{time[-1] - time[0]:.2f} s of walking is too short to analyse",
                           source)
        notes.append(f"the whole {time[-1] - time[0]:.2f} s clip analysed as one straight "
                     f"part (shorter than the {MIN_PART_S} s a part needs otherwise)")
        forward = disp[0] * e1 + disp[1] * e2
        return [Part(0, len(time), make_heading(forward, up, "overground"), travel)], notes
    parts = []
    covered = int(sum(b - a for a, b in runs))
    if covered < len(time):
        notes.append(f"{len(time) - covered} frames where the sacrum stands still or barely "
                     f"moves (< {MIN_SPEED} m/s) skipped")
    for a, b in runs:
        theta = np.unwrap(np.arctan2(vel[a:b, 1], vel[a:b, 0]))
        for c, d in _heading_chunks(theta, np.deg2rad(MAX_HEADING_DEV_DEG)):
            c, d = a + c, a + d
            if d - c < min_frames:
                notes.append(f"{time[c]:.2f}-{time[d - 1]:.2f} s skipped: turning or too short "
                             f"for a straight part (< {MIN_PART_S} s)")
                continue
            disp = path[d - 1] - path[c]
            forward = disp[0] * e1 + disp[1] * e2
            parts.append(Part(c, d, make_heading(forward, up, "overground"),
                              float(np.linalg.norm(disp))))
    if not parts:
        raise IPFError(f"no straight walking part of at least {MIN_PART_S} s: the path turns "
                       f"more than {MAX_HEADING_DEV_DEG:.0f} degrees within every stretch",
                       source)
    if len(parts) > 1:
        notes.append(f"{len(parts)} straight parts (turns or stops between them) analysed "
                     "separately")
    return parts, notes


def horizontal_basis(up: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two orthonormal horizontal (3,) vectors e1, e2 = up x e1 spanning the floor plane."""
    i = int(np.argmax(np.abs(up)))
    a = np.zeros(3)
    a[(i + 1) % 3] = 1.0
    e1 = a - (a @ up) * up
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(up, e1)


def _foot_excursion(sacrum, feet, e1, e2) -> float:
    """Largest 5-95 % range of a foot's horizontal offset from the sacrum along its main axis."""
    best = 0.0
    for heel, _toe in feet.values():
        rel = np.stack([(heel - sacrum) @ e1, (heel - sacrum) @ e2], axis=1)
        rel = rel - rel.mean(axis=0)
        axis = np.linalg.svd(rel, full_matrices=False)[2][0]
        lo, hi = np.percentile(rel @ axis, [5, 95])
        best = max(best, float(hi - lo))
    return best


def _treadmill_heading(sacrum, feet, e1, e2, up, source) -> Heading:
    """Principal axis of both feet's motion relative to the sacrum, signed by the toes."""
    offsets = [np.stack([(h - sacrum) @ e1, (h - sacrum) @ e2], axis=1) for h, _ in feet.values()]
    rel = np.concatenate([o - o.mean(axis=0) for o in offsets])
    axis = np.linalg.svd(rel, full_matrices=False)[2][0]
    forward = axis[0] * e1 + axis[1] * e2
    toes = [(toe - heel) @ forward for heel, toe in feet.values() if toe is not None]
    if not toes:
        raise IPFError("treadmill walking (sacrum nearly still) without toe points: cannot tell "
                       "forward from backward", source)
    sign = np.sign(np.nanmedian(np.concatenate(toes)))
    return make_heading(forward * (sign if sign else 1.0), up, "treadmill")


def _heading_chunks(theta: np.ndarray, max_dev: float) -> list:
    """Greedy split of headings (F,) into (start, stop) runs within ``max_dev`` of their start."""
    chunks, start = [], 0
    for i in range(1, len(theta)):
        if abs(theta[i] - theta[start]) > max_dev:
            chunks.append((start, i))
            start = i
    chunks.append((start, len(theta)))
    return chunks
