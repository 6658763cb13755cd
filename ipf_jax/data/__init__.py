"""Data in and out: calibration readers, datasets and their per-camera sources (masks, images,
videos), silhouettes by background subtraction, frame ranges, and the run-directory files
(joints.csv, poses.csv, run.json, checkpoints). See docs/formats.md.
"""
