"""Single-camera helpers: placing the person and the camera from one silhouette
(:mod:`.placement`), left/right leg swaps (:mod:`.legs`), and the ``fix-single`` post-processing
command (:mod:`.cli`). What one camera can and cannot give: docs/single_camera.md.
"""
from ...geometry.placement import (
    camera_at_height,
    camera_height_from_person,
    floor_point_single,
    person_extent,
    stand_distance,
    steady_depth,
)
from .cli import add_parser, fix_single_camera, main, run
from .legs import (
    LegSwaps,
    detect_leg_swaps,
    sagittal_legs,
    swap_leg_dofs,
    swap_leg_points,
)

__all__ = ["LegSwaps", "add_parser", "camera_at_height", "camera_height_from_person",
           "detect_leg_swaps", "fix_single_camera", "floor_point_single", "main", "person_extent",
           "run", "sagittal_legs", "stand_distance", "steady_depth", "swap_leg_dofs",
           "swap_leg_points"]
