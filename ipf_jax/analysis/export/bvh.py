"""BVH (Biovision hierarchy) export of the tracked poses, for Blender and animation tools.

The hierarchy is the body model's kinematic tree (:data:`ipf_jax.body.model.FRAMES`): ROOT
``pelvis`` (6 channels) and one JOINT per model frame, OFFSETs from the run's body shape. The BVH
rest pose (all channels 0) is the model's zero pose, standing, facing the file's reference heading.

Why the conversion is exact: BVH global axes are the file axes ``P = D U^T`` (see
:mod:`.axes`, ``D = up_rotation(up)``), and every joint's BVH local axes are the body axes seen
through ``D``. A local rotation ``R = R_a1(s1 q1) R_a2(s2 q2) ...`` then becomes
``D R D^T = R_b1(t1 s1 q1) R_b2(t2 s2 q2) ...`` where ``D e_a = t e_b`` (``D`` permutes signed
axes), i.e. one BVH rotation channel per elementary rotation, in the same order, with the signs
folded into the written angles. Joints with fewer than 3 rotations get the missing axes appended
with angle 0, because Blender's importer reads rotation channels only in threes.

Points that are not joint centres (``head``, wrists, heels, toes) sit on End Sites. A frame with
two such points (the foot: toe and heel) gets a marker JOINT at the first (``<side>_toe``, 3 rotation
channels always 0) whose End Site is the second (the heel). Missing frames hold the previous
tracked pose (the next one before the first), since BVH has no notion of a missing frame.
"""
from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

import numpy as np

from ...body.model import DOF_INDEX, FRAMES, POINTS, Pos, parse_coord
from ...data.rundir import Run, sample_rate
from ...errors import IPFError, require
from ...geometry.world import up_rotation
from .axes import decimals, file_rotation, unit_scale

_ZERO: Pos = (0, 0, 0)


class BvhNode(NamedTuple):
    """One BVH JOINT (or the ROOT), in body-model terms.

    offset = position(at) - position(base), both expressions in the parent's model frame;
    rotation : the model frame's elementary rotations (() for a marker joint);
    end : (at, base) of the End Site in this node's frame, or None.
    """

    name: str
    parent: int  # index into the skeleton, -1 for the root
    at: Pos
    base: Pos
    rotation: tuple[tuple[str, int, str], ...]
    end: tuple[Pos, Pos] | None


def _build_skeleton() -> tuple[BvhNode, ...]:
    nodes: list[BvhNode] = []

    def add(frame, parent: int) -> None:
        index = len(nodes)
        nodes.append(BvhNode(frame.name, parent, frame.origin, _ZERO, frame.rotation, None))
        children = [f for f in FRAMES if f.parent == frame.name]
        origins = [c.origin for c in children]
        # Points at the frame origin or at a child's origin are joint centres, not End Sites.
        leaves = [p for p in POINTS if p.frame == frame.name
                  and p.position != _ZERO and p.position not in origins]
        for child in children:
            add(child, index)
        if children:
            assert not leaves, f"{frame.name}: End Sites beside child joints are not supported"
            return
        assert leaves, f"{frame.name}: a leaf frame needs a point for its End Site"
        # Last-listed point first as marker joints, the first-listed one ends the chain.
        chain = leaves[::-1]
        base = _ZERO
        for point in chain[:-1]:
            nodes.append(BvhNode(point.name, index, point.position, base, (), None))
            index, base = len(nodes) - 1, point.position
        nodes[index] = nodes[index]._replace(end=(chain[-1].position, base))

    add(FRAMES[0], -1)
    return tuple(nodes)


#: The BVH hierarchy, depth first (the order of JOINTs in the file and of motion columns).
SKELETON: tuple[BvhNode, ...] = _build_skeleton()


def _vec(pos: Pos, shape_values: np.ndarray) -> np.ndarray:
    return np.array([sum(s * shape_values[i] for s, i in parse_coord(c)) for c in pos])


def _channels(node: BvhNode, D: np.ndarray) -> list[tuple[str, int, float]]:
    """Rotation channels as (BVH axis letter, DOF index or -1, coefficient on that DOF)."""
    out = []
    for axis, sign, dof in node.rotation:
        column = D[:, "xyz".index(axis)]
        b = int(np.argmax(np.abs(column)))
        out.append(("XYZ"[b], DOF_INDEX[dof], sign * float(np.sign(column[b]))))
    used = {letter for letter, _, _ in out}
    return out + [(letter, -1, 0.0) for letter in "XYZ" if letter not in used]


def _hold_missing(poses: np.ndarray, path: Path) -> np.ndarray:
    valid = np.all(np.isfinite(poses), axis=1)
    require(bool(valid.any()), "no tracked frame to export", path)
    t = np.arange(len(poses))
    last = np.maximum.accumulate(np.where(valid, t, -1))
    return poses[np.where(last >= 0, last, int(np.argmax(valid)))]


def _hierarchy(shape_values: np.ndarray, D: np.ndarray, k: float, fmt: str) -> list[str]:
    """The HIERARCHY section: OFFSETs in file axes and units, channel names from :func:`_channels`."""
    lines = ["HIERARCHY"]

    def offset(at: Pos, base: Pos) -> str:
        return "OFFSET " + " ".join(fmt % x for x in D @ (_vec(at, shape_values)
                                                          - _vec(base, shape_values)) * k)

    def emit(i: int, pad: str) -> None:
        node = SKELETON[i]
        rot = " ".join(f"{letter}rotation" for letter, _, _ in _channels(node, D))
        kind, chans = (("ROOT", "CHANNELS 6 Xposition Yposition Zposition ") if node.parent < 0
                       else ("JOINT", "CHANNELS 3 "))
        lines.extend([f"{pad}{kind} {node.name}", f"{pad}{{", f"{pad}\t{offset(node.at, node.base)}",
                      f"{pad}\t{chans}{rot}"])
        for j, child in enumerate(SKELETON):
            if child.parent == i:
                emit(j, pad + "\t")
        if node.end is not None:
            lines.extend([f"{pad}\tEnd Site", f"{pad}\t{{", f"{pad}\t\t{offset(*node.end)}",
                          f"{pad}\t}}"])
        lines.append(f"{pad}}}")

    emit(0, "")
    return lines


def _motion(poses: np.ndarray, P: np.ndarray, D: np.ndarray, k: float) -> np.ndarray:
    """(T, D) poses -> (T, C) MOTION values; columns in SKELETON order (the file's channel order)."""
    columns = [poses[:, :3] @ P.T * k]  # root position: file axes and units
    for node in SKELETON:
        for _, dof, coef in _channels(node, D):
            columns.append(np.rad2deg(coef * poses[:, dof:dof + 1]) if dof >= 0
                           else np.zeros((len(poses), 1)))
    return np.hstack(columns)


def export_bvh(run: Run, path: str | Path, *, up: str = "+y", units: str = "m") -> Path:
    """Write the run's poses (``poses.csv``) and body shape (``run.json``) as a BVH file.

    up : file up axis (BVH convention and Blender's importer: ``+y``). units : m, cm or mm for
    OFFSETs and root positions; angles are degrees.
    """
    path = Path(path)
    require(run.poses is not None, "BVH export needs poses.csv", run.path / "poses.csv")
    require(run.shape is not None, "BVH export needs the body 'shape' in run.json",
            run.path / "run.json")
    rate, k = sample_rate(run), unit_scale(units)
    D = up_rotation(up)
    P = file_rotation(run.up_axis, up)
    poses = _hold_missing(run.poses, run.path / "poses.csv")  # (T, D)
    hierarchy = _hierarchy(run.shape.values, D, k, f"%.{decimals(units)}f")
    motion = _motion(poses, P, D, k)  # (T, C)
    rows = [" ".join(f"{x:.6f}" for x in row) for row in motion]
    text = [*hierarchy, "MOTION", f"Frames: {len(rows)}",
            f"Frame Time: {1.0 / rate:.8f}", *rows]
    try:
        path.write_text("\n".join(text) + "\n")
    except OSError as e:
        raise IPFError(f"cannot write ({e})", path) from None
    return path
