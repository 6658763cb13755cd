"""The articulated body: 19 key points, 17 capsule segments, 31 DOF, 4 kinematic chains on a trunk.

Everything here is static topology (Python data), read at trace time by the JAX forward kinematics
(:mod:`ipf_jax.geometry.kinematics`) and, independently, by the NumPy reference
(:mod:`ipf_jax.geometry.host`).

Body frame convention (every local frame, at zero angles): ``x`` forward (anterior), ``y`` to the
subject's left, ``z`` up. The root frame is the pelvis, located at the ``sacrum`` point. The world
frame is the calibration's; its up axis is mapped onto the body's ``z`` by a fixed rotation ``U``
(see :func:`ipf_jax.geometry.camera.up_rotation`), so root yaw is always a turn about the world's up axis.

Angles are radians inside the library (files and CLI show degrees where they say so); positive
directions are anatomical and the same for both sides: flexion, abduction (away from the midline),
internal rotation, dorsiflexion, inversion.
"""
from __future__ import annotations

from typing import NamedTuple

# --------------------------------------------------------------------------------------------------
# Key points (J = 19). Names and order are part of the file formats (joints.csv).
POINT_NAMES: tuple[str, ...] = (
    "sacrum",
    "left_hip", "left_knee", "left_ankle", "left_heel", "left_toe",
    "right_hip", "right_knee", "right_ankle", "right_heel", "right_toe",
    "neck", "head",
    "left_shoulder", "left_elbow", "left_wrist",
    "right_shoulder", "right_elbow", "right_wrist",
)
NUM_POINTS = len(POINT_NAMES)
POINT_INDEX = {n: i for i, n in enumerate(POINT_NAMES)}

#: The 12 limb joint centres whose anatomy agrees across mocap sources (used for MPJPE).
LIMB_JOINTS: tuple[str, ...] = (
    "left_hip", "left_knee", "left_ankle", "right_hip", "right_knee", "right_ankle",
    "left_shoulder", "left_elbow", "left_wrist", "right_shoulder", "right_elbow", "right_wrist",
)

#: Bones drawn in overlays and exports (pairs of point names); the 4 kinematic chains plus trunk.
BONES: tuple[tuple[str, str], ...] = (
    ("sacrum", "left_hip"), ("left_hip", "left_knee"), ("left_knee", "left_ankle"),
    ("left_ankle", "left_heel"), ("left_ankle", "left_toe"), ("left_heel", "left_toe"),
    ("sacrum", "right_hip"), ("right_hip", "right_knee"), ("right_knee", "right_ankle"),
    ("right_ankle", "right_heel"), ("right_ankle", "right_toe"), ("right_heel", "right_toe"),
    ("sacrum", "neck"), ("neck", "head"),
    ("neck", "left_shoulder"), ("left_shoulder", "left_elbow"), ("left_elbow", "left_wrist"),
    ("neck", "right_shoulder"), ("right_shoulder", "right_elbow"), ("right_elbow", "right_wrist"),
)


# --------------------------------------------------------------------------------------------------
# Degrees of freedom (D = 31): root translation (3) + root rotation (3) + 25 joint angles.
class Dof(NamedTuple):
    name: str
    unit: str  # "m" or "rad"
    meaning: str


DOFS: tuple[Dof, ...] = (
    Dof("root_tx", "m", "sacrum position, world x"),
    Dof("root_ty", "m", "sacrum position, world y"),
    Dof("root_tz", "m", "sacrum position, world z"),
    Dof("root_yaw", "rad", "heading: turn about the world up axis (periodic)"),
    Dof("root_pitch", "rad", "pelvis forward tilt"),
    Dof("root_roll", "rad", "pelvis tilt to the subject's left"),
    Dof("trunk_flexion", "rad", "trunk bends forward (lumbar)"),
    Dof("trunk_lateral", "rad", "trunk bends to the left"),
    Dof("trunk_rotation", "rad", "trunk turns to the left"),
    Dof("head_flexion", "rad", "head/neck nods forward"),
    Dof("head_lateral", "rad", "head/neck bends to the left"),
    Dof("left_hip_flexion", "rad", "thigh forward"),
    Dof("left_hip_abduction", "rad", "thigh away from the midline"),
    Dof("left_hip_rotation", "rad", "internal rotation of the thigh"),
    Dof("left_knee_flexion", "rad", "shank backward; 0 = straight, never negative"),
    Dof("left_ankle_dorsiflexion", "rad", "toes up"),
    Dof("left_ankle_inversion", "rad", "sole turns toward the midline"),
    Dof("right_hip_flexion", "rad", "thigh forward"),
    Dof("right_hip_abduction", "rad", "thigh away from the midline"),
    Dof("right_hip_rotation", "rad", "internal rotation of the thigh"),
    Dof("right_knee_flexion", "rad", "shank backward; 0 = straight, never negative"),
    Dof("right_ankle_dorsiflexion", "rad", "toes up"),
    Dof("right_ankle_inversion", "rad", "sole turns toward the midline"),
    Dof("left_shoulder_flexion", "rad", "upper arm forward"),
    Dof("left_shoulder_abduction", "rad", "upper arm away from the body"),
    Dof("left_shoulder_rotation", "rad", "internal rotation of the upper arm"),
    Dof("left_elbow_flexion", "rad", "forearm forward/up; 0 = straight"),
    Dof("right_shoulder_flexion", "rad", "upper arm forward"),
    Dof("right_shoulder_abduction", "rad", "upper arm away from the body"),
    Dof("right_shoulder_rotation", "rad", "internal rotation of the upper arm"),
    Dof("right_elbow_flexion", "rad", "forearm forward/up; 0 = straight"),
)
DOF_NAMES: tuple[str, ...] = tuple(d.name for d in DOFS)
NUM_DOF = len(DOFS)
DOF_INDEX = {n: i for i, n in enumerate(DOF_NAMES)}
TRANSLATION_DOFS = (0, 1, 2)
PERIODIC_DOFS = (DOF_INDEX["root_yaw"],)
#: The paper's 'interesting' sub-vector L: the four leg flexion angles.
DEFAULT_INTERESTING: tuple[str, ...] = (
    "left_hip_flexion", "left_knee_flexion", "right_hip_flexion", "right_knee_flexion",
)

# --------------------------------------------------------------------------------------------------
# Kinematic tree. A position is three coordinates; each is 0, a signed shape-parameter name
# ("+thigh", "-hip_down") or a tuple of them (summed). A rotation is a product of elementary rotations (axis, sign, dof), applied in order:
# R = R_axis1(sign1 * q1) @ R_axis2(sign2 * q2) @ ...
Pos = tuple[object, object, object]


class Frame(NamedTuple):
    name: str
    parent: str | None
    origin: Pos  # in the parent frame
    rotation: tuple[tuple[str, int, str], ...]


def _leg(side: str, s: int) -> tuple[Frame, ...]:
    # s = +1 left, -1 right: mirrored abduction / rotation / inversion signs.
    hw = "+hip_half_width" if s > 0 else "-hip_half_width"
    return (
        Frame(f"{side}_thigh", "pelvis", ("+hip_forward", hw, "-hip_down"),
              (("y", -1, f"{side}_hip_flexion"), ("x", s, f"{side}_hip_abduction"),
               ("z", -s, f"{side}_hip_rotation"))),
        Frame(f"{side}_shank", f"{side}_thigh", (0, 0, "-thigh"),
              (("y", 1, f"{side}_knee_flexion"),)),
        Frame(f"{side}_foot", f"{side}_shank", (0, 0, "-shank"),
              (("y", -1, f"{side}_ankle_dorsiflexion"), ("x", -s, f"{side}_ankle_inversion"))),
    )


def _arm(side: str, s: int) -> tuple[Frame, ...]:
    sw = "+shoulder_half_width" if s > 0 else "-shoulder_half_width"
    return (
        Frame(f"{side}_upper_arm", "trunk", (0, sw, ("+trunk", "-shoulder_drop")),
              (("y", -1, f"{side}_shoulder_flexion"), ("x", s, f"{side}_shoulder_abduction"),
               ("z", -s, f"{side}_shoulder_rotation"))),
        Frame(f"{side}_forearm", f"{side}_upper_arm", (0, 0, "-upper_arm"),
              (("y", -1, f"{side}_elbow_flexion"),)),
    )


FRAMES: tuple[Frame, ...] = (
    # The root: origin = root translation, rotation = U @ Rz(yaw) Ry(pitch) Rx(-roll).
    Frame("pelvis", None, (0, 0, 0),
          (("z", 1, "root_yaw"), ("y", 1, "root_pitch"), ("x", -1, "root_roll"))),
    Frame("trunk", "pelvis", (0, 0, 0),
          (("y", 1, "trunk_flexion"), ("x", -1, "trunk_lateral"), ("z", 1, "trunk_rotation"))),
    Frame("head", "trunk", (0, 0, "+trunk"),
          (("y", 1, "head_flexion"), ("x", -1, "head_lateral"))),
    *_leg("left", 1), *_leg("right", -1), *_arm("left", 1), *_arm("right", -1),
)
FRAME_NAMES = tuple(f.name for f in FRAMES)
FRAME_INDEX = {n: i for i, n in enumerate(FRAME_NAMES)}


class Point(NamedTuple):
    name: str
    frame: str
    position: Pos


def _leg_points(side: str) -> tuple[Point, ...]:
    hw = "+hip_half_width" if side == "left" else "-hip_half_width"
    return (
        Point(f"{side}_hip", "pelvis", ("+hip_forward", hw, "-hip_down")),
        Point(f"{side}_knee", f"{side}_thigh", (0, 0, "-thigh")),
        Point(f"{side}_ankle", f"{side}_shank", (0, 0, "-shank")),
        Point(f"{side}_heel", f"{side}_foot", ("-heel_back", 0, "-heel_down")),
        Point(f"{side}_toe", f"{side}_foot", ("+toe_forward", 0, "-toe_down")),
    )


def _arm_points(side: str) -> tuple[Point, ...]:
    sw = "+shoulder_half_width" if side == "left" else "-shoulder_half_width"
    return (
        Point(f"{side}_shoulder", "trunk", (0, sw, ("+trunk", "-shoulder_drop"))),
        Point(f"{side}_elbow", f"{side}_upper_arm", (0, 0, "-upper_arm")),
        Point(f"{side}_wrist", f"{side}_forearm", (0, 0, "-forearm")),
    )


_POINTS = (
    Point("sacrum", "pelvis", (0, 0, 0)),
    *_leg_points("left"), *_leg_points("right"),
    Point("neck", "trunk", (0, 0, "+trunk")),
    Point("head", "head", (0, 0, "+neck")),
    *_arm_points("left"), *_arm_points("right"),
)
POINTS: tuple[Point, ...] = tuple(sorted(_POINTS, key=lambda p: POINT_INDEX[p.name]))
assert tuple(p.name for p in POINTS) == POINT_NAMES


class Segment(NamedTuple):
    """A rigid capsule: hull of two spheres (centres a, b in one frame; radii r_a, r_b)."""

    name: str
    frame: str
    a: Pos
    b: Pos
    r_a: str
    r_b: str


def _limb_segments(side: str) -> tuple[Segment, ...]:
    return (
        Segment(f"{side}_thigh", f"{side}_thigh", (0, 0, 0), (0, 0, "-thigh"), "thigh_r0", "thigh_r1"),
        Segment(f"{side}_shank", f"{side}_shank", (0, 0, 0), (0, 0, "-shank"), "shank_r0", "shank_r1"),
        Segment(f"{side}_foot", f"{side}_foot", ("-foot_back", 0, "-foot_down"),
                ("+foot_tip", 0, "-foot_tip_down"), "foot_r0", "foot_r1"),
    )


def _arm_segments(side: str) -> tuple[Segment, ...]:
    return (
        Segment(f"{side}_upper_arm", f"{side}_upper_arm", (0, 0, 0), (0, 0, "-upper_arm"),
                "upper_arm_r0", "upper_arm_r1"),
        Segment(f"{side}_forearm", f"{side}_forearm", (0, 0, 0), (0, 0, "-forearm"),
                "forearm_r0", "forearm_r1"),
        Segment(f"{side}_hand", f"{side}_forearm", (0, 0, "-forearm"), (0, 0, ("-forearm", "-hand")),
                "hand_r0", "hand_r1"),
    )


SEGMENTS: tuple[Segment, ...] = (
    # the pelvis capsule reaches crotch_depth below the hip joints (its axis pelvis_r above that)
    Segment("pelvis", "pelvis", (0, "+hip_half_width", ("-hip_down", "-crotch_depth", "+pelvis_r")),
            (0, "-hip_half_width", ("-hip_down", "-crotch_depth", "+pelvis_r")), "pelvis_r", "pelvis_r"),
    Segment("trunk_left", "trunk", (0, "+trunk_half_width_low", "+trunk_low"),
            (0, "+trunk_half_width_high", ("+trunk", "-trunk_top_gap")), "trunk_r_low", "trunk_r_high"),
    Segment("trunk_right", "trunk", (0, "-trunk_half_width_low", "+trunk_low"),
            (0, "-trunk_half_width_high", ("+trunk", "-trunk_top_gap")), "trunk_r_low", "trunk_r_high"),
    Segment("neck", "head", (0, 0, 0), (0, 0, "+neck"), "neck_r", "neck_r"),
    Segment("head", "head", ("+head_forward", 0, ("+neck", "+head_low")),
            ("+head_forward", 0, ("+neck", "+head_high")),
            "head_r", "head_r"),
    *_limb_segments("left"), *_limb_segments("right"),
    *_arm_segments("left"), *_arm_segments("right"),
)
NUM_SEGMENTS = len(SEGMENTS)
SEGMENT_NAMES = tuple(s.name for s in SEGMENTS)

#: Every shape parameter the tree refers to (metres), in a fixed order: BodyShape.values layout.
SHAPE_PARAM_NAMES: tuple[str, ...] = (
    "hip_half_width", "hip_down", "thigh", "shank",
    "heel_back", "heel_down", "toe_forward", "toe_down",
    "foot_back", "foot_down", "foot_tip", "foot_tip_down",
    "trunk", "shoulder_half_width", "shoulder_drop", "neck",
    "upper_arm", "forearm", "hand",
    "crotch_depth", "trunk_low", "trunk_top_gap", "trunk_half_width_low", "trunk_half_width_high",
    "head_forward", "head_low", "head_high",
    "pelvis_r", "trunk_r_low", "trunk_r_high", "neck_r", "head_r",
    "thigh_r0", "thigh_r1", "shank_r0", "shank_r1", "foot_r0", "foot_r1",
    "upper_arm_r0", "upper_arm_r1", "forearm_r0", "forearm_r1", "hand_r0", "hand_r1",
    "hip_forward",
)
SHAPE_INDEX = {n: i for i, n in enumerate(SHAPE_PARAM_NAMES)}
#: Parameters added after shape files were first written, with the value that keeps an older
#: document's body as it was: ``hip_forward`` 0 put the hip joints in the pelvis capsule's plane.
LEGACY_PARAMS = {"hip_forward": 0.0}

assert NUM_POINTS == 19 and NUM_SEGMENTS == 17 and NUM_DOF == 31


def parse_coord(coord: object) -> tuple[tuple[float, int], ...]:
    """A position coordinate as a tuple of (sign, shape-parameter index) terms to sum (() = 0)."""
    if coord == 0:
        return ()
    terms = coord if isinstance(coord, tuple) else (coord,)
    out = []
    for term in terms:
        assert isinstance(term, str) and term[0] in "+-", term
        out.append((1.0 if term[0] == "+" else -1.0, SHAPE_INDEX[term[1:]]))
    return tuple(out)


def _check_tree() -> None:
    seen: set[str] = set()
    for f in FRAMES:
        assert f.parent is None or f.parent in seen, f"frame {f.name} before its parent"
        seen.add(f.name)
        [parse_coord(t) for t in f.origin]
        for _, _, dof in f.rotation:
            assert dof in DOF_INDEX, dof
    used = {d for f in FRAMES for _, _, d in f.rotation}
    assert used | {"root_tx", "root_ty", "root_tz"} == set(DOF_NAMES), "every DOF drives the tree"
    for p in POINTS:
        assert p.frame in seen
        [parse_coord(t) for t in p.position]
    for s in SEGMENTS:
        assert s.frame in seen
        [parse_coord(t) for t in (*s.a, *s.b)]
        SHAPE_INDEX[s.r_a], SHAPE_INDEX[s.r_b]


_check_tree()
