"""Interoperability with Intel PARSEC *bodytrack* (a peer annealed-particle-filter body tracker).

Modules: :mod:`.io` (pose, shape and BMP readers), :mod:`.kinematics` (bodytrack's forward
kinematics), :mod:`.overlay` (its cone projection and Result overlays), :mod:`.fit` (comparison
with, and initialisation of, ipf-jax's body). Everything is NumPy float64.

The bodytrack pose convention
-----------------------------
A pose is 31 numbers (radians; the pelvis position in mm, world frame of the ``CameraK.cal``
files, +Z up, floor at Z = 0). Every joint rotation is ``E(a, b, c) = Rz(c) Rx(a) Ry(b)``, and a
child frame is its parent frame times ``E^-1`` (bodytrack stores parent-in-child rotations):

====================  ==========================================================================
indices               meaning
====================  ==========================================================================
0-2, 3-5              pelvis rotation E(v0, v1, v2) and position (mm): the pelvis frame
6-8, 9                left hip E, left knee (about y);   10-12, 13: the same on the right
14-15, 16-18, 19      left clavicle E(v14, v15, 0), shoulder E, elbow (about y)
20-21, 22-24, 25      the same on the right
26-27                 thorax relative to pelvis E(0, v26, v27)
28-30                 head/neck E
====================  ==========================================================================

In the pelvis frame +x is forward, +y the subject's left, +z up (the foreground masks of
sequenceB confirm it: both feet extend along +x from the ankles). Legs hang from
``pelvis * RotY(180)`` shifted by ``lengths[1]`` (left, +y) or ``-lengths[5]`` (right); each leg
cone runs along its local +z (thigh ``lengths[2]``/``[6]``, shin ``[3]``/``[7]``). The thorax frame is
``pelvis * RotX(180) * E_thorax^-1`` moved ``lengths[0]`` along its -z: the thorax pivots about
the pelvis origin, while the torso cone stays rigid with the pelvis. The clavicles leave it through bodytrack's ``XRot90`` (left) / ``XRot270`` (right),
ending ``lengths[9]``/``[13]`` away at the shoulders; a fixed re-orientation then leads to the upper
arm and forearm cones, which run along local **-z** (``lengths[10..11]``, ``[14..15]``). The head
cone starts at the thorax origin and runs ``lengths[17]`` up. BodyShapeParameters.txt gives per
part [bottom radius, top radius, x scale, y scale] (elliptic torso and head).

Validated by re-drawing bodytrack's own Result overlay: for its frame-0 and frame-1 estimates the
re-drawn mosaic equals bodytrack's pixel for pixel (camera k in column k % 2, row k // 2).

How bodytrack's points map to ours
----------------------------------
``left/right_hip``, ``_knee``, ``_ankle``, ``_shoulder``, ``_elbow``, ``_wrist`` are cone ends at
the joint centres and correspond to ours (:data:`.fit.SHARED_JOINTS`). ``sacrum`` here is
bodytrack's pelvis origin, on the line between the hip joints (ours is ``hip_down`` higher);
``neck`` is the thorax origin, at shoulder height between the clavicles; ``head`` is the base of the head cone, the same point as ``neck``
(ours is ``neck`` higher, at the skull base); ``head_top`` has no counterpart. Those four are for
drawing and rough checks, not for joint-error statistics.
"""
from .fit import SHARED_JOINTS, OurFit, fit_our_pose, mean_joint_distance, peer_joints
from .io import (
    PART_NAMES,
    BodytrackShape,
    read_bmp,
    read_body_shape,
    read_fg_mask,
    read_pose,
)
from .kinematics import (
    POINT_NAMES,
    BodytrackGeometry,
    BodytrackParts,
    bodytrack_geometry,
    bodytrack_points,
    bodytrack_points_batch,
    euler_zxy,
)
from .overlay import (
    Agreement,
    agreement,
    axis_samples,
    cone_outlines,
    fg_fraction,
    fg_hits,
    read_overlay,
    render_overlay,
)

__all__ = [
    "PART_NAMES", "POINT_NAMES", "SHARED_JOINTS", "BodytrackShape", "BodytrackParts",
    "BodytrackGeometry", "OurFit", "Agreement", "read_pose", "read_body_shape", "read_bmp",
    "read_fg_mask", "euler_zxy", "bodytrack_geometry", "bodytrack_points", "bodytrack_points_batch",
    "cone_outlines", "axis_samples", "fg_hits", "fg_fraction", "render_overlay", "read_overlay",
    "agreement", "peer_joints", "mean_joint_distance", "fit_our_pose",
]
