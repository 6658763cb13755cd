"""``ipf-jax fix-single RUN_DIR --out DIR``: single-camera post-processing of a tracked run
(:func:`ipf_jax.analysis.singlecam.fix_single_camera`)."""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from ..analysis.singlecam import MEETING_M, MIN_GAIN_M, fix_single_camera
from ..errors import IPFError, require
from ..geometry.camera import Camera
from .options import add_common, flag


def add_parser(subparsers) -> argparse.ArgumentParser:
    """``fix-single RUN_DIR --out DIR``: single-camera post-processing of a tracked run."""
    p = subparsers.add_parser(
        "fix-single", help="single-camera post-processing of a run: correct left/right leg swaps "
        "and steady the depth, into a new run folder",
        description="Detect and correct left/right leg swaps (docs/single_camera.md) and move each "
                    "frame's body along its viewing ray to a steady depth from the camera. Writes "
                    "joints.csv, poses.csv and run.json into --out.")
    p.add_argument("run_dir", help="a folder written by ipf-jax track (one camera)")
    add_common(p, "out", help="folder for the corrected run (not RUN_DIR)")
    add_common(p, "dataset", help="dataset folder for the camera (default: run.json's)")
    add_common(p, "camera", help="camera name or 1-based number (default: the only one)")
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
    from ..data.dataset import open_dataset, pick_cameras

    meta_path = Path(args.run_dir) / "run.json"
    try:
        meta = json.loads(meta_path.read_text())
    except (OSError, ValueError) as e:
        raise IPFError(f"cannot read run.json ({e})", meta_path) from None
    used = meta.get("cameras") if isinstance(meta, dict) else None
    require(not isinstance(used, list) or len(used) == 1, "fix-single corrects single-camera runs; "
            f"this run used {len(used or [])} cameras ({', '.join(map(str, used or []))})", meta_path)
    recorded = meta.get("dataset")
    path = args.dataset
    if path is None:
        path = recorded
        require(isinstance(path, str) and Path(path).exists(), "the run's dataset is not found "
                "from here: give --dataset (or --keep-depth)", meta_path)
    cams = open_dataset(path).cameras
    require(args.camera is not None or len(cams) == 1,
            f"the dataset has {len(cams)} cameras: say which with --camera", path)
    cam = cams[pick_cameras(cams, args.camera, flag("camera"))[0] if args.camera else 0]
    require(not used or cam.name == used[0], f"the run was tracked with camera {used and used[0]}, "
            f"not {cam.name}: the depth is steadied along the run's own camera", path)
    if isinstance(recorded, str) and Path(recorded).exists() and not Path(recorded).samefile(path):
        theirs = {c.name: c for c in open_dataset(recorded).cameras}.get(cam.name)
        require(theirs is None or (np.allclose(theirs.K, cam.K) and np.allclose(theirs.R, cam.R)
                                   and np.allclose(theirs.T, cam.T)),
                f"camera {cam.name} of this dataset is not the one the run was tracked with "
                f"(calibration of {recorded})", path)
    return cam


def run(args: argparse.Namespace) -> int:
    require(0 < args.min_gain < np.inf, f"--min-gain must be > 0 and finite (got {args.min_gain})")
    require(0 <= args.meeting < np.inf, f"--meeting must be >= 0 and finite (got {args.meeting})")
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
