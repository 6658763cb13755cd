"""Analysis of tracked (or marker) trajectories: gait, accuracy evaluation, exports, the bodytrack peer,
single-camera post-processing, and the filter comparison.
"""
