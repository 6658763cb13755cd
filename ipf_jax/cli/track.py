"""``ipf-jax track DATASET --out DIR``: track a dataset into joints.csv, poses.csv, run.json."""
from __future__ import annotations

from pathlib import Path

from ..errors import require
from .options import (
    add_tracking_options,
    check_settings,
    filter_options,
    floor_range,
    init_settings,
    initial_pose,
)


def add_parser(sub) -> None:
    p = sub.add_parser("track", help="track a dataset: joints.csv, poses.csv, run.json")
    p.add_argument("dataset")
    p.add_argument("--out", required=True)
    add_tracking_options(p)
    p.add_argument("--resume", action="store_true", help="continue an interrupted run in --out")
    p.add_argument("--checkpoint-every", type=int, default=10)
    p.add_argument("--overlay", action="store_true", help="save overlay PNGs of the fitted model")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


def run(args) -> int:
    from ..data.dataset import open_dataset
    from ..data.frames import select_frames
    from ..tracking.tracker import DEFAULT_RESOLUTION, TrackSettings
    from ..tracking.tracker import track as run_track
    from ..viz.overlay import overlay_writer

    check_settings(args)
    ds = open_dataset(args.dataset)
    frames = select_frames(ds.frames, args.frames)
    init_pose, height = (None, args.height) if not args.init_pose else initial_pose(args)
    require(args.chunk >= 1, f"--chunk must be >= 1 (got {args.chunk})")
    require(args.checkpoint_every >= 1, f"--checkpoint-every must be >= 1 (got {args.checkpoint_every})")
    settings = TrackSettings(
        filter=args.filter, filter_options=filter_options(args), budget=args.budget,
        resolution=args.resolution or DEFAULT_RESOLUTION, fps=args.fps, height_m=height,
        shape_file=args.shape, limits=args.limits, up_axis=args.up, seed=args.seed, chunk=args.chunk,
        kernel=args.kernel, checkpoint_every=args.checkpoint_every, init_pose=init_pose,
        floor_range=floor_range(args),
        init=init_settings(args))
    res = run_track(ds, args.out, settings, frames=frames, resume=args.resume,
                    progress=not args.quiet,
                    frame_hook=overlay_writer(Path(args.out) / "overlay") if args.overlay else None)
    run = res.run
    print(f"tracked {run['frames']['done']} frames ({run['frames']['missing']} missing) of {ds.name} "
          f"with {run['filter']} ({run['evaluations_per_frame']} evaluations/frame), "
          f"{run['seconds']['per_tracked_frame_mean']} s/frame; up axis {run['up_axis']}, "
          f"height {run['height_m']:.2f} m; re-initialised at {run['reinitialisations'] or 'no frame'}")
    print(f"wrote {Path(args.out) / 'joints.csv'}, poses.csv, run.json")
    return 0
