"""``ipf-jax track DATASET --out DIR``: track a dataset into joints.csv, poses.csv, run.json."""
from __future__ import annotations

import gc
import warnings
from pathlib import Path

from ..errors import IPFWarning, require
from .options import (
    add_common,
    add_tracking_options,
    check_args,
    flag,
    settings_from_args,
)


def add_parser(sub) -> None:
    p = sub.add_parser("track", help="track a dataset: joints.csv, poses.csv, run.json",
                       description="Track a person through a dataset's frames (automatic "
                                   "initialisation, then one filter step per frame) and write "
                                   "joints.csv, poses.csv and run.json into --out (docs/formats.md).")
    p.add_argument("dataset", help="a dataset folder: bodytrack layout or a dataset.json "
                                   "(docs/formats.md)")
    add_common(p, "out", help="output folder (created); with --resume, the interrupted run's")
    add_tracking_options(p)
    p.add_argument("--resume", action="store_true", help="continue an interrupted run in --out "
                   "(same settings and data: the files come out byte-identical)")
    p.add_argument("--overlay", action="store_true", help="also save overlay PNGs of the fitted "
                   "model in --out/overlay")
    add_common(p, "smooth", help="also write joints_smoothed.csv: the joints low-passed by the gait "
               "analysis' zero-lag filter (5 Hz, at most fps/4); joints.csv stays raw")
    add_common(p, "quiet")
    p.set_defaults(func=run)


def run(args) -> int:
    from ..data.dataset import open_dataset
    from ..data.frames import select_frames
    from ..tracking.passes import track
    from ..viz.overlay import overlay_writer

    values = check_args(args)
    ds = open_dataset(args.dataset)
    frames = select_frames(ds.frames, values.get("frames"), where=flag("frames"))
    settings = settings_from_args(args, values)
    # said once the inputs are read: a bad one is then the only line, and the run stays as it was
    previous = [n for n in ("run.json", "checkpoint.npz") if (Path(args.out) / n).exists()]
    if previous and not args.resume:
        warnings.warn(f"{args.out} holds a previous run ({', '.join(previous)}): its files are "
                      "replaced (--resume continues it instead)", IPFWarning, stacklevel=1)
    # the process's objects so far (JAX, NumPy, OpenCV: most of its millions) outlive the run:
    # frozen while it runs, the collector's full passes do not walk them (one such pass cost
    # 100-300 ms in the middle of a tracked frame, about one per 12-40 frames); unfrozen after,
    # so an in-process caller's garbage among them is collected as usual
    gc.freeze()
    try:
        res = track(ds, args.out, settings, frames=frames, resume=args.resume,
                    progress=not args.quiet,
                    frame_hook=overlay_writer(Path(args.out) / "overlay") if args.overlay else None)
    finally:
        gc.unfreeze()
    run = res.run
    written = ["joints.csv", "poses.csv", "run.json"]
    if args.smooth:
        from ..analysis.export.smoothed import write_smoothed

        written.append(write_smoothed(args.out).name)
    counts = run["frames"]
    per_frame = run["seconds"]["per_tracked_frame_mean"]
    print(f"{counts['done']} frames of {ds.name}: {counts['done'] - counts['missing'] - counts['lost']} "
          f"with an estimate, {counts['lost']} lost, {counts['missing']} missing (nobody in the masks); "
          f"{run['filter']} ({run['evaluations_per_frame']} evaluations/frame), "
          f"{'-' if per_frame is None else per_frame} s/tracked frame; up axis {run['up_axis']}, "
          f"height {run['height_m']:.2f} m; re-initialised at {run['reinitialisations'] or 'no frame'}")
    fit = run.get("shape_fit")
    if fit:
        print(f"shape fitted ({run['shape_source']}): {fit['evaluations']} evaluations, "
              f"{fit['seconds']:.1f} s (initialisation: {run['init_evaluations']} evaluations)")
    print(f"wrote {', '.join(written + ['shape.json'])} to {args.out}")
    seen = counts["done"] - counts["missing"]
    if seen > 0 and 2 * counts["lost"] > seen:  # most of the track is no track
        warnings.warn(IPFWarning(
            f"{counts['lost']} of {seen} frames with someone in view were lost (the body found does "
            "not explain the silhouettes: check the calibration against the masks, e.g. with "
            f"ipf-jax render {args.out})"))
    require(counts["missing"] < counts["done"], f"no frame of {ds.name} shows anyone: every camera's "
            "mask is empty, specks only or nearly all foreground on every frame; check the masks' "
            "foreground threshold or the background model (run.json's mask_quality says so frame "
            "by frame)", args.out)
    return 0
