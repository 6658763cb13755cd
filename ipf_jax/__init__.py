"""ipf-jax: markerless 3D motion capture and gait analysis by Interval Particle Filtering.

Pipeline (one module per stage): body model -> kinematics -> camera -> raster -> likelihood ->
filters (ipf, apf, sir) -> tracker -> gait; I/O and CLI at the edge.
"""
__version__ = "0.1.0"
