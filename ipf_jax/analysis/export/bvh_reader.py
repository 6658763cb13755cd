"""Read any BVH file and compute its joint and End Site positions (standard BVH semantics).

Independent of the body model on purpose: it checks :mod:`.bvh` against the file format, not
against the writer's own assumptions. Semantics: a joint's transform relative to its parent is
``translate(OFFSET + position channels) @ R_c1 @ R_c2 @ ...`` with one rotation per rotation
channel in the order listed, angles in degrees, acting on column vectors.
"""
from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

import numpy as np

from ...errors import IPFError, require


class BvhFile(NamedTuple):
    """A BVH file (K nodes: joints and End Sites, depth first; T frames).

    names : (K,) joint names; an End Site is ``<its joint>.end``.  parents : (K,) index, -1 = root.
    offsets : (K, 3).  channels : per node, the channel names (End Sites: none).
    motion : (T, C) values in file order.  frame_time : seconds.
    """

    names: tuple[str, ...]
    parents: tuple[int, ...]
    offsets: np.ndarray
    channels: tuple[tuple[str, ...], ...]
    motion: np.ndarray
    frame_time: float


_CHANNELS = {f"{a}{kind}" for a in "XYZ" for kind in ("position", "rotation")}


def read_bvh(path: str | Path) -> BvhFile:
    """Parse a BVH file; raises :class:`IPFError` on malformed input."""
    path = Path(path)
    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError) as e:
        raise IPFError(f"not a readable BVH file ({e})", path) from None
    head, sep, tail = text.partition("MOTION")
    require(bool(sep) and head.split()[:1] == ["HIERARCHY"],
            "not a BVH file (needs HIERARCHY and MOTION sections)", path)
    tokens = head.split()[1:]
    names: list[str] = []
    parents: list[int] = []
    offsets: list[list[float]] = []
    channels: list[tuple[str, ...]] = []
    stack: list[int] = []
    i = 0
    try:
        while i < len(tokens):
            tok = tokens[i]
            if tok in ("ROOT", "JOINT") or tok == "End":
                end = tok == "End"
                require(not end or tokens[i + 1] == "Site", f"expected 'End Site' at {tok!r}", path)
                require(tokens[i + 2] == "{" and tokens[i + 3] == "OFFSET",
                        f"{tokens[i + 1]}: expected '{{ OFFSET'", path)
                names.append(f"{names[stack[-1]]}.end" if end else tokens[i + 1])
                parents.append(stack[-1] if stack else -1)
                offsets.append([float(x) for x in tokens[i + 4:i + 7]])
                i += 7
                chans: tuple[str, ...] = ()
                if not end and tokens[i] == "CHANNELS":
                    n = int(tokens[i + 1])
                    chans = tuple(tokens[i + 2:i + 2 + n])
                    require(all(c in _CHANNELS for c in chans), f"{names[-1]}: bad channels", path)
                    i += 2 + n
                channels.append(chans)
                stack.append(len(names) - 1)
            elif tok == "}":
                stack.pop()
                i += 1
            else:
                raise IPFError(f"unexpected token {tok!r} in HIERARCHY", path)
        lines = [line.split() for line in tail.splitlines() if line.strip()]
        require(lines[0][0] == "Frames:" and lines[1][:2] == ["Frame", "Time:"],
                "MOTION needs 'Frames:' and 'Frame Time:' lines", path)
        n_frames, frame_time = int(lines[0][1]), float(lines[1][2])
        motion = np.array([[float(x) for x in line] for line in lines[2:]], float)
    except (IndexError, ValueError) as e:
        raise IPFError(f"malformed BVH ({e})", path) from None
    n_chan = sum(len(c) for c in channels)
    require(not stack, "unbalanced braces in HIERARCHY", path)
    require(motion.shape == (n_frames, n_chan),
            f"MOTION is {motion.shape}, expected ({n_frames}, {n_chan})", path)
    return BvhFile(tuple(names), tuple(parents), np.array(offsets), tuple(channels), motion,
                   frame_time)


def _rotations(axis: str, degrees: np.ndarray) -> np.ndarray:
    """(T,) angles about one axis -> (T, 3, 3)."""
    a = np.deg2rad(degrees)
    c, s = np.cos(a), np.sin(a)
    i, j = {"X": (1, 2), "Y": (2, 0), "Z": (0, 1)}[axis]
    R = np.zeros((len(a), 3, 3))
    R[:, "XYZ".index(axis), "XYZ".index(axis)] = 1.0
    R[:, i, i], R[:, i, j], R[:, j, i], R[:, j, j] = c, -s, s, c
    return R


def bvh_positions(bvh: BvhFile) -> np.ndarray:
    """Global positions of every node (joints and End Sites), file units and axes.

    Returns (T, K, 3), nodes in ``bvh.names`` order.
    """
    T = len(bvh.motion)
    rot = np.zeros((len(bvh.names), T, 3, 3))
    pos = np.zeros((len(bvh.names), T, 3))
    col = 0
    for k, parent in enumerate(bvh.parents):
        R = np.broadcast_to(np.eye(3), (T, 3, 3))
        t = np.broadcast_to(bvh.offsets[k], (T, 3)).copy()
        for name in bvh.channels[k]:
            values = bvh.motion[:, col]
            col += 1
            if name.endswith("position"):
                t[:, "XYZ".index(name[0])] += values
            else:
                R = R @ _rotations(name[0], values)
        if parent < 0:
            rot[k], pos[k] = R, t
        else:
            rot[k] = rot[parent] @ R
            pos[k] = pos[parent] + np.einsum("tij,tj->ti", rot[parent], t)
    return pos.transpose(1, 0, 2)
