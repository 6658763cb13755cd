"""Named poses and floor contact: standing/stride/swing configurations placed on the floor."""
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
