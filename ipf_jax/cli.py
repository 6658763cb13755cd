"""Command line: a thin layer over the library. ``ipf-jax --help`` lists the commands.

Every user-fixable problem is an :class:`ipf_jax.errors.IPFError`: printed as one line
``error: <file>: <problem>`` on stderr with exit status 2, never a traceback.
"""
from __future__ import annotations

import argparse
import os
import sys
import warnings

from . import __version__
from .errors import IPFError, IPFWarning


def _slice(text: str) -> slice:
    from .frames import parse_frames

    try:
        return parse_frames(text)
    except IPFError as e:
        raise argparse.ArgumentTypeError(e.message) from None


def _range(text: str) -> tuple[float, float]:
    try:
        lo, hi = (float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"--floor-range must look like LO,HI in metres (got {text!r})") from None
    if not lo <= hi:
        raise argparse.ArgumentTypeError(f"--floor-range needs LO <= HI (got {text!r})")
    return lo, hi


def add_tracking_options(p: argparse.ArgumentParser) -> None:
    """Options shared by track, compare, and the sweep/batch configs."""
    p.add_argument("--filter", default="ipf", help="ipf (default), apf or sir")
    p.add_argument("--budget", type=int, help="likelihood evaluations per frame; each filter maps it onto its parameters")
    p.add_argument("--particles", type=int, help="IPF: total particles N = M x I (largest M that fits)")
    p.add_argument("--top-m", type=int, help="IPF: M, the distinct particles kept per frame (default 81)")
    p.add_argument("--points-per-dof", type=int, help="IPF: grid points per interesting DOF (default 3 -> I = 81)")
    p.add_argument("--interval-width", type=float,
                   help="IPF: full interval width in degrees per frame (overrides --max-speed)")
    p.add_argument("--max-speed", type=float, help="IPF: maximum angular speed of the interesting DOFs, deg/s")
    p.add_argument("--interesting", help="IPF: comma-separated DOF names forming L (default: the 4 leg flexions)")
    p.add_argument("--noise-scale", type=float, help="multiply the default per-DOF noise rates")
    p.add_argument("--layers", type=int, help="APF: annealing layers (default 5)")
    p.add_argument("--resolution", type=int, default=None, help="long side of the scoring images, px (default 320)")
    p.add_argument("--fps", type=float, help="frame rate (default: from the video, else 20 Hz)")
    p.add_argument("--height", type=float, help="subject height in metres (default: searched at initialisation)")
    p.add_argument("--shape", help="subject shape JSON (default adult, scaled by --height)")
    p.add_argument("--limits", default="default", help="DOF limits preset (default, walking) or JSON file")
    p.add_argument("--up", help="world up axis (+x -x +y -y +z -z; default detected)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--chunk", type=int, default=512, help="particles per compiled call")
    p.add_argument("--kernel", default="scanline", choices=["scanline", "dense"])
    p.add_argument("--frames", type=_slice, help="frame numbers A:B (B excluded), A:, A:B:S or A")
    p.add_argument("--init-budget", default="default", choices=["default", "small"],
                   help="effort of the automatic initialisation: small searches ~10x fewer "
                        "configurations (quick looks, tests); default is the full search")
    p.add_argument("--init-pose", help="initial pose: poses.csv row file, or bodytrack InitialPose.txt")
    p.add_argument("--floor-range", type=_range, default=None, metavar="LO,HI",
                   help="floor contact constraint (off by default): keep the body's lowest surface "
                        "point LO..HI m above the floor, e.g. --floor-range=-0.03,0.10 (with '=': "
                        "the value starts with '-') (see ipf_jax.contact)")


#: Commands living in their own modules: each exposes ``add_parser(subparsers)`` that sets
#: ``func=run`` (``run(args) -> int`` handles IPFError itself or lets :func:`main` do it).
#: name -> (module, one-line help). Only the invoked command's module is imported (they pull in
#: JAX, SciPy and matplotlib, seconds of start-up); the others appear in ``--help`` by name.
MODULE_COMMANDS = {
    "gait": ("ipf_jax.gait.cli", "gait events and parameters from joints.csv, .trc or .c3d"),
    "export": ("ipf_jax.export.cli", "write tracking results as TRC, C3D, BVH or CSV"),
    "compare": ("ipf_jax.compare", "IPF, APF and SIR side by side at the same likelihood budget"),
    "eval": ("ipf_jax.evaluation.cli", "3D error of an estimate against a reference (MPJPE, per joint, per axis)"),
    "sweep": ("ipf_jax.sweep.cli", "accuracy vs cost over a grid of settings (resumable; local or Ray)"),
    "batch": ("ipf_jax.sweep.cli", "track many recordings with one set of settings (resumable; local or Ray)"),
    "bench": ("ipf_jax.bench", "throughput of the measure step (JAX vs NumPy) and tracking s/frame"),
    "render": ("ipf_jax.render", "overlay video/images of a tracked run over each camera's frames or masks"),
    "fix-single": ("ipf_jax.singlecam.cli", "single-camera post-processing of a run: leg swaps, steady depth"),
    "init-dataset": ("ipf_jax.init_dataset_cli", "write a dataset.json for videos or image folders and a calibration"),
    "calibrate": ("ipf_jax.calibrate_cli", "camera calibration from checkerboard/ChArUco images or videos -> cameras.json"),
}


def _invoked(argv: list[str]) -> str | None:
    """The sub-command named on the command line (the first argument not starting with -)."""
    return next((a for a in argv if not a.startswith("-")), None)


def _add_module_commands(sub, argv: list[str]) -> None:
    import importlib

    chosen = _invoked(argv)
    if chosen in MODULE_COMMANDS:
        importlib.import_module(MODULE_COMMANDS[chosen][0]).add_parser(sub)
        return
    for name, (_, help_text) in MODULE_COMMANDS.items():  # listed in --help, parsed when invoked
        sub.add_parser(name, help=help_text, add_help=False)


def _parser(argv: list[str] | None = None) -> argparse.ArgumentParser:

    ap = argparse.ArgumentParser(prog="ipf-jax", description="Markerless 3D motion capture and gait "
                                 "analysis by Interval Particle Filtering (JAX).")
    ap.add_argument("--version", action="version", version=f"ipf-jax {__version__}")
    ap.add_argument("--debug", action="store_true",
                    help="show the full traceback of an internal error (a bug) instead of one line")
    sub = ap.add_subparsers(dest="command", required=True)

    p = sub.add_parser("demo", help="self-rendered walk: render, track, report error and speed (no downloads)")
    p.add_argument("--out", default="ipf-jax-demo", help="output folder (default ./ipf-jax-demo)")
    p.add_argument("--frames", type=int, default=24, help="frames to track (default 24)")
    p.add_argument("--cameras", type=int, default=3)
    p.add_argument("--top-m", type=int, default=None, help="IPF M (default 81)")
    p.add_argument("--seed", type=int, default=0)
    p.set_defaults(func="demo")

    p = sub.add_parser("track", help="track a dataset: joints.csv, poses.csv, run.json")
    p.add_argument("dataset")
    p.add_argument("--out", required=True)
    add_tracking_options(p)
    p.add_argument("--resume", action="store_true", help="continue an interrupted run in --out")
    p.add_argument("--checkpoint-every", type=int, default=10)
    p.add_argument("--overlay", action="store_true", help="save overlay PNGs of the fitted model")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func="track")

    p = sub.add_parser("score", help="likelihood of given poses on one frame (JAX and/or NumPy)")
    p.add_argument("dataset")
    p.add_argument("--frame", type=int, required=True)
    p.add_argument("--poses", required=True, help="CSV with one named column per DOF (poses.csv convention)")
    p.add_argument("--out", required=True, help="output JSON")
    p.add_argument("--backend", default="jax", choices=["jax", "numpy", "both"])
    p.add_argument("--resolution", type=int, default=None)
    p.add_argument("--height", type=float, default=None)
    p.add_argument("--shape")
    p.add_argument("--up")
    p.set_defaults(func="score")

    _add_module_commands(sub, sys.argv[1:] if argv is None else argv)
    return ap


def main(argv: list[str] | None = None) -> int:
    ap = _parser(argv)
    args = ap.parse_args(argv)
    warnings.showwarning = _show_warning
    try:
        from . import commands, jax_setup

        jax_setup.configure()
        if not isinstance(args.func, str):  # commands living in their own modules
            return args.func(args)
        return getattr(commands, args.func)(args)
    except IPFError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted (rows written so far are kept; rerun with --resume)", file=sys.stderr)
        return 130
    except BrokenPipeError:
        os._exit(1)
    except Exception as e:  # a bug: one line (exit 70, EX_SOFTWARE), the traceback with --debug
        if args.debug:
            raise
        print(f"error: internal error in {args.command}: {type(e).__name__}: {_one_line(e)} "
              "(rerun with --debug for the traceback)", file=sys.stderr)
        return INTERNAL_ERROR


INTERNAL_ERROR = 70  # sysexits.h EX_SOFTWARE
_default_showwarning = warnings.showwarning


def _show_warning(message, category, filename, lineno, file=None, line=None):
    """IPFWarnings as one ``warning: ...`` line; other warnings as Python shows them."""
    if issubclass(category, IPFWarning):
        print(f"warning: {message}", file=sys.stderr)
    else:
        _default_showwarning(message, category, filename, lineno, file, line)


def _one_line(e: BaseException) -> str:
    text = " ".join(str(e).split())
    return text if len(text) <= 300 else text[:297] + "..."


if __name__ == "__main__":
    sys.exit(main())
