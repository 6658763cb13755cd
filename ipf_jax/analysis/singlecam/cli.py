"""``ipf-jax fix-single RUN_DIR --out DIR``: single-camera post-processing of a tracked run.

Corrects left/right leg swaps (:mod:`.legs`) and steadies the depth (:func:`.placement.steady_depth`)
into a new run folder; the tracker's own output is kept as it is.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from ...errors import IPFError, require
from ...geometry.camera import Camera
from ...geometry.placement import steady_depth
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
    from ...data.rundir import joints_from_poses, read_run, write_table
    from ...data.runfiles import JOINT_COLUMNS, POSE_COLUMNS, check_writable
    from ...geometry.world import axis_vector

    run = read_run(run_dir)
    out = check_writable(Path(out_dir))
    require(out.resolve() != run.path.resolve(), "write the corrected run to another folder "
            "(the tracker's output is kept as it is)", out)
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
    write_table(out / "joints.csv", JOINT_COLUMNS, run.frames, run.time_s, joints.reshape(T, -1))
    if poses is not None:
        write_table(out / "poses.csv", POSE_COLUMNS, run.frames, run.time_s, poses)
    meta = dict(run.meta)
    meta["single_camera"] = record
    (out / "run.json").write_text(json.dumps(meta, indent=1))
    return record


def add_parser(subparsers) -> argparse.ArgumentParser:
    """``fix-single RUN_DIR --out DIR``: single-camera post-processing of a tracked run."""
    p = subparsers.add_parser(
        "fix-single", help="single-camera post-processing of a run: correct left/right leg swaps "
        "and steady the depth, into a new run folder",
        description="Detect and correct left/right leg swaps (docs/single_camera.md) and move each "
                    "frame's body along its viewing ray to a steady depth from the camera. Writes "
                    "joints.csv, poses.csv and run.json into --out.")
    p.add_argument("run_dir")
    p.add_argument("--out", required=True, help="folder for the corrected run (not RUN_DIR)")
    p.add_argument("--dataset", help="dataset folder for the camera (default: run.json's)")
    p.add_argument("--camera", help="camera name or 1-based number (default: the only one)")
    p.add_argument("--keep-legs", action="store_true", help="do not correct leg swaps")
    p.add_argument("--keep-depth", action="store_true", help="do not steady the depth")
    p.add_argument("--min-gain", type=float, default=MIN_GAIN_M,
                   help=f"metres by which exchanged labels must fit better (default {MIN_GAIN_M})")
    p.add_argument("--meeting", type=float, default=MEETING_M,
                   help=f"metres by which the ankles' separation must dip to count as a meeting; "
                        f"legs that meet and part on the same sides were swapped (default "
                        f"{MEETING_M}; 0 = walking not assumed)")
    p.set_defaults(func=run)
    return p


def _run_camera(args) -> Camera:
    from ...data.dataset import open_dataset
    from ...viz.render import pick_cameras

    path = args.dataset
    if path is None:
        meta_path = Path(args.run_dir) / "run.json"
        try:
            path = json.loads(meta_path.read_text()).get("dataset")
        except (OSError, ValueError) as e:
            raise IPFError(f"cannot read run.json ({e})", meta_path) from None
        require(isinstance(path, str) and Path(path).exists(), "the run's dataset is not found "
                "from here: give --dataset (or --keep-depth)", meta_path)
    cams = open_dataset(path).cameras
    require(args.camera is not None or len(cams) == 1,
            f"the dataset has {len(cams)} cameras: say which with --camera", path)
    return cams[pick_cameras(cams, args.camera, "--camera")[0] if args.camera else 0]


def run(args: argparse.Namespace) -> int:
    require(args.min_gain > 0, f"--min-gain must be > 0 (got {args.min_gain})")
    require(args.meeting >= 0, f"--meeting must be >= 0 (got {args.meeting})")
    camera = None if args.keep_depth else _run_camera(args)
    rec = fix_single_camera(args.run_dir, args.out, legs=not args.keep_legs, camera=camera,
                            min_gain_m=args.min_gain, meeting_m=args.meeting or None)
    done = []
    if rec["leg_swaps"] is not None:
        sw = rec["leg_swaps"]
        done.append(f"{len(sw['swap_frames'])} leg swap(s) at frame(s) "
                    f"{sw['swap_frames'] or '-'} ({sw['exchanged_frames']} frames exchanged)")
    if rec["steady_depth"] is not None:
        sd = rec["steady_depth"]
        done.append(f"depth steadied to {sd['depth_m']:.2f} m from {sd['camera']} (largest shift "
                    f"{sd['max_shift_m']:.2f} m)")
    print("; ".join(done or ["nothing to do"]) + f"; wrote {args.out}")
    return 0


def main(argv: list[str] | None = None) -> int:
    """``python -m ipf_jax.analysis.singlecam fix-single RUN_DIR --out DIR``."""
    parser = argparse.ArgumentParser(prog="ipf-jax")
    add_parser(parser.add_subparsers(dest="command", required=True))
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except IPFError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2


