"""Smoothed joints: the tracked trajectory through the gait analysis' own zero-lag low-pass.

One filter for every use: :func:`ipf_jax.analysis.gait.filtering.lowpass` (second-order
Butterworth run forward and backward, 5 Hz by default, capped at a quarter of the frame rate),
applied to each finite stretch of each point; missing frames stay missing. The raw
``joints.csv`` is always kept: ``joints_smoothed.csv`` is written beside it (``ipf-jax track
--smooth``) or the smoothed joints are exported (``ipf-jax export --smooth``).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ...data.rundir import Run, read_run, sample_rate
from ...data.runfiles import JOINT_COLUMNS, write_rows
from ..gait.filtering import DEFAULT_CUTOFF_HZ, effective_cutoff, lowpass

NAME = "joints_smoothed.csv"


def smooth_joints(run: Run, cutoff_hz: float = DEFAULT_CUTOFF_HZ) -> tuple[np.ndarray, float]:
    """(T, J, 3) the run's joints low-passed, and the cut-off used (Hz)."""
    fps = sample_rate(run)
    cutoff = effective_cutoff(cutoff_hz, fps)
    return lowpass(run.joints, fps, cutoff), cutoff


def write_smoothed(run_dir: str | Path, cutoff_hz: float = DEFAULT_CUTOFF_HZ) -> Path:
    """Write ``RUN_DIR/joints_smoothed.csv`` (the joints.csv convention); returns its path."""
    run = read_run(run_dir)
    joints, _ = smooth_joints(run, cutoff_hz)
    path = Path(run_dir) / NAME
    write_rows(path, JOINT_COLUMNS, run.frames, run.time_s, joints.reshape(len(joints), -1))
    return path
