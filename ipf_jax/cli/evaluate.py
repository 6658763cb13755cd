"""``ipf-jax eval ESTIMATE.csv TRUTH.csv --out DIR [--joints A,B] [--align none|rigid]``.

Thin over :func:`ipf_jax.analysis.evaluation.evaluate_files` and :func:`ipf_jax.analysis.evaluation.write_outputs`.
A user mistake (unreadable file, no shared joints, no overlapping time) is an IPFError, printed by
the main CLI as one line with exit status 2.
"""
from __future__ import annotations

import argparse

from ..analysis.evaluation.metrics import ALIGN_MODES
from ..errors import require
from .options import add_common


def add_parser(subparsers) -> argparse.ArgumentParser:
    """Add the ``eval`` sub-command to the main CLI's sub-parsers (sets ``func=run``)."""
    p = subparsers.add_parser(
        "eval", help="3D error of an estimate against a reference (MPJPE, per joint, per axis)",
        description="Score a joints.csv-convention estimate against a reference in the same "
                    "convention (e.g. 20 Hz tracking vs 100 Hz motion capture: the reference is "
                    "interpolated at the estimate's time_s). Writes eval.json, per_frame.csv and "
                    "displacement.png (paper figure 7) into --out. See docs/evaluation.md.")
    p.add_argument("estimate", metavar="ESTIMATE.csv", help="estimate, e.g. a run's joints.csv")
    p.add_argument("truth", metavar="TRUTH.csv", help="reference, e.g. ground_truth.csv")
    add_common(p, "out")
    p.add_argument("--joints", help="comma-separated names to score (default: the 12 limb joints "
                                    "when both files have them, else every shared name)")
    p.add_argument("--align", choices=ALIGN_MODES, default="none",
                   help="none (default) or rigid: remove one rotation + translation first")
    p.add_argument("--no-plots", action="store_true", help="skip displacement.png")
    p.set_defaults(func=run)
    return p


def split_table(ev) -> str:
    """Per scored joint: MPJPE, constant offset (length and x/y/z) and offset-free error, in mm."""
    sp = ev.split
    lines = [f"{'joint':<16}{'MPJPE':>8}{'offset':>8}   {'offset x/y/z':<20}{'offset-free':>12}"]
    for k, n in enumerate(sp.names):
        xyz = "/".join(f"{1000 * v:.0f}" for v in sp.offset[k])
        lines.append(f"{n:<16}{1000 * sp.mpjpe_m[k]:>8.1f}{1000 * sp.offset_m[k]:>8.1f}   "
                     f"{xyz:<20}{1000 * sp.offset_free_m[k]:>12.1f}")
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    """Evaluate; prints one summary line. IPFError propagates to the main CLI (exit 2)."""
    from ..analysis.evaluation.metrics import evaluate_files, systematic_doc
    from ..analysis.evaluation.report import write_outputs
    from ..body.model import LIMB_JOINTS

    joints = [j.strip() for j in args.joints.split(",") if j.strip()] if args.joints is not None else None
    require(joints is None or joints, f"--joints {args.joints!r} names no joint")
    ev, _, truth = evaluate_files(args.estimate, args.truth, joints=joints, align=args.align)
    files = write_outputs(ev, truth, args.out, plots=not args.no_plots,
                          extra={"estimate": str(args.estimate), "truth": str(args.truth)})
    what = "the 12 limb joints" if ev.scored == LIMB_JOINTS else f"{len(ev.scored)} joints"
    sysdoc = systematic_doc(ev)
    print(f"MPJPE {1000 * ev.mpjpe_m:.1f} mm over {int(ev.scored_frames.sum())} frames ({what}, "
          f"align {args.align}); once each joint's constant offset is removed "
          f"{1000 * sysdoc['mpjpe_offset_free_m']:.1f} mm (mean offset "
          f"{1000 * sysdoc['mean_offset_m']:.1f} mm); rms x/y/z "
          + "/".join(f"{1000 * v:.1f}" for v in ev.rms_axis_m.values()) + " mm")
    print(split_table(ev))
    print(f"wrote {', '.join(f.name for f in files)} to {args.out}")
    return 0
