"""The NumPy reference: the same pipeline as the JAX kernels, simple and obviously right.

It mirrors the JAX API name for name (``forward_kinematics``, ``project_points``,
``project_capsules``, ``counts``) and is the oracle in tests: pixel counts must be equal exactly
given the same 2D capsules; geometry agrees to :data:`GEOMETRY_ATOL_M` / :data:`PIXEL_ATOL`.
"""
GEOMETRY_ATOL_M = 1e-5  # metres: FK in float32 (JAX) vs float64 (NumPy)
PIXEL_ATOL = 2e-3  # pixels: projection float32 vs float64 (and vs OpenCV projectPoints)
