"""Named poses and floor contact: standing/stride/swing configurations and the postures beyond
walking (bending, crouching, sitting, rising), placed on the floor."""
from __future__ import annotations

import numpy as np

from ..body.model import DOF_INDEX, NUM_DOF
from .host import forward_kinematics

#: Coarse leg configurations (hip flexion, knee flexion) left/right in degrees, for initialisation.
LEG_CONFIGS_DEG: tuple[tuple[float, float, float, float], ...] = (
    (5, 5, 5, 5),  # standing
    (25, 5, -10, 10),  # left foot forward
    (-10, 10, 25, 5),  # right foot forward
    (20, 50, -5, 5),  # left leg swinging
    (-5, 5, 20, 50),  # right leg swinging
)

#: Postures beyond walking for initialisation and recovery: (trunk flexion, hip flexion, knee
#: flexion, ankle dorsiflexion) in degrees, both sides alike, the pelvis upright. Sitting is the
#: seat height of a chair (thighs level, shanks vertical): a chair in the silhouette is not
#: modelled, the body is fitted around it.
POSTURES_DEG: dict[str, tuple[float, float, float, float]] = {
    "bend": (60, 15, 5, 0),  # bending forward from the hips, knees nearly straight
    "crouch": (45, 110, 125, 20),  # squatting, heels down as far as the ankle allows
    "sit": (10, 90, 90, 0),  # seated upright
    "rise": (45, 70, 70, 10),  # leaning forward off a chair seat
}


def posture_pose(trunk: float, hip: float, knee: float, ankle: float, heading: float = 0.0) -> np.ndarray:
    """(D,) a symmetric posture from its trunk, hip, knee and ankle flexions (degrees, see
    :data:`POSTURES_DEG`); hands forward of the knees as when sitting or crouching."""
    q = np.zeros(NUM_DOF)
    q[DOF_INDEX["root_yaw"]] = heading
    q[DOF_INDEX["trunk_flexion"]] = np.deg2rad(trunk)
    for side in ("left", "right"):
        q[DOF_INDEX[f"{side}_hip_flexion"]] = np.deg2rad(hip)
        q[DOF_INDEX[f"{side}_knee_flexion"]] = np.deg2rad(knee)
        q[DOF_INDEX[f"{side}_ankle_dorsiflexion"]] = np.deg2rad(ankle)
        q[DOF_INDEX[f"{side}_shoulder_flexion"]] = np.deg2rad(min(0.5 * hip, 45.0))
        q[DOF_INDEX[f"{side}_shoulder_abduction"]] = np.deg2rad(8.0)
        q[DOF_INDEX[f"{side}_elbow_flexion"]] = np.deg2rad(30.0)
    return q


def gait_pose(hip_l: float, knee_l: float, hip_r: float, knee_r: float, heading: float = 0.0) -> np.ndarray:
    """(D,) a walking-like pose from four leg angles (degrees); arms swing against the legs."""
    q = np.zeros(NUM_DOF)
    q[DOF_INDEX["root_yaw"]] = heading
    for side, hip, knee, other in (("left", hip_l, knee_l, hip_r), ("right", hip_r, knee_r, hip_l)):
        q[DOF_INDEX[f"{side}_hip_flexion"]] = np.deg2rad(hip)
        q[DOF_INDEX[f"{side}_knee_flexion"]] = np.deg2rad(knee)
        q[DOF_INDEX[f"{side}_shoulder_flexion"]] = np.deg2rad(0.6 * other)
        q[DOF_INDEX[f"{side}_shoulder_abduction"]] = np.deg2rad(8.0)
        q[DOF_INDEX[f"{side}_elbow_flexion"]] = np.deg2rad(20.0)
    return q


def lowest_height(q: np.ndarray, shape_values: np.ndarray, U: np.ndarray) -> float:
    """Height above the floor (up . X = 0) of the lowest capsule surface point of pose ``q``."""
    up = U[:, 2]
    pose = forward_kinematics(q, shape_values, U)
    return float(min(np.min(pose.seg_a @ up - pose.seg_r[:, 0]), np.min(pose.seg_b @ up - pose.seg_r[:, 1])))


def place_on_floor(q: np.ndarray, shape_values: np.ndarray, U: np.ndarray) -> np.ndarray:
    """The same pose moved along world up so its lowest point touches the floor."""
    q = np.array(q, float)
    q[:3] -= U[:, 2] * lowest_height(q, shape_values, U)
    return q
