"""Geometry: cameras and their projection (JAX), the world's up axis, forward kinematics (JAX for
particles, NumPy float64 on the host), projected capsules, viewing rays, single-view placement,
pose transfer between bodies (retarget).
"""
