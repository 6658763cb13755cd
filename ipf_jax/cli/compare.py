"""``ipf-jax compare``: the filters side by side (:mod:`ipf_jax.analysis.compare`); see docs/compare.md."""
from __future__ import annotations

import argparse
import math

from ..analysis.compare import (
    COLUMNS,
    compare,
    load_peer,
    load_truth,
    markdown_table,
    parse_filters,
)
from ..errors import require
from ..tracking.options import check_value
from .options import (
    add_common,
    add_option,
    add_tracking_options,
    flag,
    settings_from_args,
    values_from_args,
)


def add_parser(subparsers) -> argparse.ArgumentParser:
    """Add the ``compare`` sub-command (sets ``func=run``)."""
    p = subparsers.add_parser(
        "compare", help="IPF, APF and SIR side by side at the same likelihood budget",
        description="Track the same frames with each filter at the same number of likelihood "
                    "evaluations per frame, from the same initial pose; write compare.csv, "
                    "compare.md, compare.json and compare.png into --out, and each filter's run "
                    "into --out/<filter>/. See docs/compare.md.")
    p.add_argument("dataset", help="a dataset folder (bodytrack layout or a dataset.json)")
    add_common(p, "out")
    add_tracking_options(p, exclude=("filter", "budget"))
    p.add_argument("--filters", flag("filter"), dest="filters", default="ipf,fipf,apf,sir",
                   help="comma-separated filters (default ipf,fipf,apf,sir)")
    add_option(p, "budget", required=True, help="likelihood evaluations per frame, the same for "
               "every filter")
    p.add_argument("--truth", help="reference joints, a CSV in the joints.csv convention")
    p.add_argument("--peer", help="a bodytrack poses file (one 31-number pose per frame)")
    p.add_argument("--peer-shape", help="bodytrack BodyShapeParameters.txt (default: in the dataset)")
    p.add_argument("--peer-seconds", type=float, help="the peer's measured seconds per frame, for the table")
    p.add_argument("--repeat", type=int, default=1,
                   help="run each filter R times (identical runs) and time every step by its fastest run")
    add_common(p, "quiet", help="no progress bars")
    p.set_defaults(func=run)
    return p


def run(args: argparse.Namespace) -> int:
    """Run the comparison; prints the table. IPFError propagates to the main CLI (exit 2)."""
    from ..data.dataset import open_dataset
    from ..data.frames import select_frames

    names = parse_filters(args.filters)
    values = values_from_args(args)
    for key, value in values.items():  # each option's rule; the filters are checked by compare()
        check_value(key, value, flag(key))
    require(args.peer_seconds is None or (args.peer and math.isfinite(args.peer_seconds)
                                          and args.peer_seconds > 0),
            f"--peer-seconds {args.peer_seconds} needs --peer and must be > 0 seconds per frame")
    require(args.peer_shape is None or args.peer, f"--peer-shape {args.peer_shape} needs --peer (the "
            "bodytrack poses it gives the body of)")
    ds = open_dataset(args.dataset)
    frames = select_frames(ds.frames, values.get("frames"), where=flag("frames"))
    refs = ([load_truth(args.truth)] if args.truth else []) + (
        [load_peer(args.peer, ds, args.peer_shape)] if args.peer else [])
    settings = settings_from_args(args, {k: v for k, v in values.items() if k != "budget"})
    res = compare(ds, args.out, names, args.budget, settings=settings, frames=frames, references=refs,
                  peer_seconds=args.peer_seconds, repeat=args.repeat, progress=not args.quiet)
    print(markdown_table(res.rows, list(COLUMNS)))
    print(f"wrote {', '.join(p.name for p in res.files)} to {args.out} (runs in {args.out}/<filter>/)")
    return 0
