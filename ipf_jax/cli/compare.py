"""``ipf-jax compare``: the filters side by side (:mod:`ipf_jax.analysis.compare`); see docs/compare.md."""
from __future__ import annotations

import argparse

from ..analysis.compare import (
    COLUMNS,
    TrackSettings,
    compare,
    load_peer,
    load_truth,
    markdown_table,
    parse_filters,
)
from ..errors import require


def add_parser(subparsers) -> argparse.ArgumentParser:
    """Add the ``compare`` sub-command (sets ``func=run``)."""
    from .options import add_tracking_options

    p = subparsers.add_parser(
        "compare", conflict_handler="resolve",
        help="IPF, APF and SIR side by side at the same likelihood budget",
        description="Track the same frames with each filter at the same number of likelihood "
                    "evaluations per frame, from the same initial pose; write compare.csv, "
                    "compare.md, compare.json and compare.png into --out, and each filter's run "
                    "into --out/<filter>/. See docs/compare.md.")
    p.add_argument("dataset")
    p.add_argument("--out", required=True, help="output folder (created)")
    add_tracking_options(p)
    p.add_argument("--filters", "--filter", dest="filters", default="ipf,apf,sir",
                   help="comma-separated filters (default ipf,apf,sir)")
    p.add_argument("--budget", type=int, required=True,
                   help="likelihood evaluations per frame, the same for every filter")
    p.add_argument("--truth", help="reference joints, a CSV in the joints.csv convention")
    p.add_argument("--peer", help="a bodytrack poses file (one 31-number pose per frame)")
    p.add_argument("--peer-shape", help="bodytrack BodyShapeParameters.txt (default: in the dataset)")
    p.add_argument("--peer-seconds", type=float, help="the peer's measured seconds per frame, for the table")
    p.add_argument("--repeat", type=int, default=1,
                   help="run each filter R times (identical runs) and time every step by its fastest run")
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    p.set_defaults(func=run)
    return p


def run(args: argparse.Namespace) -> int:
    """Run the comparison; prints the table. IPFError propagates to the main CLI (exit 2)."""
    from ..data.dataset import open_dataset
    from ..data.frames import select_frames
    from ..tracking.tracker import DEFAULT_RESOLUTION
    from .options import filter_options, floor_range, init_settings, initial_pose

    names = parse_filters(args.filters)
    require(args.budget >= 1, f"--budget must be >= 1 evaluation per frame (got {args.budget})")
    ds = open_dataset(args.dataset)
    frames = select_frames(ds.frames, args.frames)
    init_pose, height = (None, args.height) if not args.init_pose else initial_pose(args)
    refs = ([load_truth(args.truth)] if args.truth else []) + (
        [load_peer(args.peer, ds, args.peer_shape)] if args.peer else [])
    shared = {k: getattr(args, k) for k in ("fps", "limits", "seed", "chunk", "kernel")}
    settings = TrackSettings(filter_options=filter_options(args), height_m=height, init_pose=init_pose,
                             resolution=args.resolution or DEFAULT_RESOLUTION, shape_file=args.shape,
                             up_axis=args.up, floor_range=floor_range(args),
                             init=init_settings(args), **shared)
    res = compare(ds, args.out, names, args.budget, settings=settings, frames=frames, references=refs,
                  peer_seconds=args.peer_seconds, repeat=args.repeat, progress=not args.quiet)
    print(markdown_table(res.rows, list(COLUMNS)))
    print(f"wrote {', '.join(p.name for p in res.files)} to {args.out} (runs in {args.out}/<filter>/)")
    return 0
