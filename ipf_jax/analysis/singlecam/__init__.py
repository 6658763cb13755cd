"""Single-camera post-processing: left/right leg swaps (:mod:`.legs`) and the ``fix-single``
correction of a run (:mod:`.fix`). Placing the person and the camera from one silhouette is
geometry (:mod:`ipf_jax.geometry.placement`). What one camera can and cannot give:
docs/single_camera.md.
"""
from .fix import fix_single_camera
from .legs import (
    MEETING_M,
    MIN_GAIN_M,
    RATIO,
    LegSwaps,
    detect_leg_swaps,
    sagittal_legs,
    swap_leg_dofs,
    swap_leg_points,
)

__all__ = ["MEETING_M", "MIN_GAIN_M", "RATIO", "LegSwaps", "detect_leg_swaps", "fix_single_camera",
           "sagittal_legs", "swap_leg_dofs", "swap_leg_points"]
