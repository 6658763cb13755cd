"""Single-camera post-processing of a tracked run: leg swaps corrected, depth steadied.

Corrects left/right leg swaps (:mod:`.legs`) and steadies the depth
(:func:`ipf_jax.geometry.placement.steady_depth`) into a new run folder; the tracker's own output
is kept as it is. ``ipf-jax fix-single`` (:mod:`ipf_jax.cli.fix_single`) is the command.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ...data.rundir import joints_from_poses, read_run
from ...data.runfiles import JOINT_COLUMNS, POSE_COLUMNS, check_writable, write_rows
from ...errors import load_json, require
from ...geometry.camera import Camera
from ...geometry.placement import steady_depth
from ...geometry.world import axis_vector
from .legs import (
    MEETING_M,
    MIN_GAIN_M,
    RATIO,
    detect_leg_swaps,
    swap_leg_dofs,
    swap_leg_points,
)


def fix_single_camera(run_dir: str | Path, out_dir: str | Path, *, legs: bool = True,
                      camera: Camera | None = None, min_gain_m: float = MIN_GAIN_M,
                      ratio: float = RATIO, meeting_m: float | None = MEETING_M) -> dict:
    """Post-process a single-camera run into ``out_dir`` (joints.csv, poses.csv, run.json).

    legs : correct leg swaps (:func:`detect_leg_swaps`); with poses.csv and a shape the leg DOFs
        are exchanged and the joints recomputed by forward kinematics, otherwise the points are.
    camera : when given, also steady the depth (:func:`steady_depth`; root translated too).
    run.json gains ``single_camera`` (what was done, with the swap frames). Returns that record.
    """
    run = read_run(run_dir)
    out = check_writable(Path(out_dir))
    require(out.resolve() != run.path.resolve(), "write the corrected run to another folder "
            "(the tracker's output is kept as it is)", out)
    kept = out / "run.json"  # another run's folder: its files would be mixed with these
    doc = load_json(kept, "run.json") if kept.exists() else {"single_camera": None}
    require(isinstance(doc, dict) and "single_camera" in doc, "holds a tracked run (run.json): write "
            "the corrected run to a new folder (only an earlier fix-single output is replaced)", out)
    up = axis_vector(run.up_axis)
    joints, poses = run.joints, run.poses
    record: dict = {"source_run": str(run.path), "leg_swaps": None, "steady_depth": None}
    if legs:
        found = detect_leg_swaps(joints, up, run.frames, min_gain_m=min_gain_m, ratio=ratio,
                                 meeting_m=meeting_m)
        if poses is not None and run.shape is not None:
            poses = swap_leg_dofs(poses, found.parity)
            joints = joints_from_poses(poses, run.shape, run.up_axis)
        else:
            joints = swap_leg_points(joints, found.parity)
        record["leg_swaps"] = {"swap_frames": run.frames[found.swaps].tolist(),
                               "exchanged_frames": int(found.parity.sum()),
                               "min_gain_m": min_gain_m, "ratio": ratio, "meeting_m": meeting_m}
    if camera is not None:
        shifts, fit = steady_depth(joints, camera, up, run.frames)
        joints = joints + shifts[:, None]
        if poses is not None:
            poses = poses.copy()
            poses[:, :3] += shifts  # the root translation carries the whole body
        record["steady_depth"] = {"camera": camera.name, "depth_m": round(float(fit[0]), 4),
                                  "slope_m_per_frame": round(float(fit[1]), 6),
                                  "max_shift_m": round(float(np.abs(shifts).max()), 4)}
    T = len(run.frames)
    write_rows(out / "joints.csv", JOINT_COLUMNS, run.frames, run.time_s, joints.reshape(T, -1))
    if poses is not None:
        write_rows(out / "poses.csv", POSE_COLUMNS, run.frames, run.time_s, poses)
    meta = dict(run.meta)
    meta["single_camera"] = record
    (out / "run.json").write_text(json.dumps(meta, indent=1))
    return record
