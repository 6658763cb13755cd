"""Command line: a thin layer over the library. ``ipf-jax --help`` lists the commands.

Every user-fixable problem is an :class:`ipf_jax.errors.IPFError`: printed as one line
``error: <file>: <problem>`` on stderr with exit status 2, never a traceback.
"""
from __future__ import annotations

import argparse
import os
import signal
import sys
import threading
import warnings

from .. import __version__, stop
from ..errors import IPFError, IPFWarning

#: Commands living in their own modules: each exposes ``add_parser(subparsers)`` that sets
#: ``func=run`` (``run(args) -> int`` handles IPFError itself or lets :func:`main` do it).
#: name -> (module, one-line help). Only the invoked command's module is imported (they pull in
#: JAX, SciPy and matplotlib, seconds of start-up); the others appear in ``--help`` by name.
MODULE_COMMANDS = {
    "demo": ("ipf_jax.cli.demo", "self-rendered walk: render, track, report error and speed (no downloads)"),
    "track": ("ipf_jax.cli.track", "track a dataset: joints.csv, poses.csv, run.json"),
    "score": ("ipf_jax.cli.score", "likelihood of given poses on one frame (JAX and/or NumPy)"),
    "gait": ("ipf_jax.cli.gait", "gait events and parameters from joints.csv, .trc or .c3d"),
    "export": ("ipf_jax.cli.export", "write tracking results as TRC, C3D, BVH or CSV"),
    "compare": ("ipf_jax.cli.compare", "IPF, APF and SIR side by side at the same likelihood budget"),
    "eval": ("ipf_jax.cli.evaluate", "3D error of an estimate against a reference (MPJPE, per joint, per axis)"),
    "sweep": ("ipf_jax.cli.sweep", "accuracy vs cost over a grid of settings (resumable; local or Ray)"),
    "batch": ("ipf_jax.cli.sweep", "track many recordings with one set of settings (resumable; local or Ray)"),
    "bench": ("ipf_jax.cli.bench", "throughput of the measure step (JAX vs NumPy) and tracking s/frame"),
    "render": ("ipf_jax.cli.render", "overlay video/images of a tracked run over each camera's frames or masks"),
    "init-dataset": ("ipf_jax.cli.init_dataset", "write a dataset.json for videos or image folders and a calibration"),
    "calibrate": ("ipf_jax.cli.calibrate", "camera calibration from checkerboard/ChArUco images or videos -> cameras.json"),
    "fix-single": ("ipf_jax.cli.fix_single", "single-camera post-processing of a run: leg swaps, steady depth"),
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


class OneLineParser(argparse.ArgumentParser):
    """argparse's usage errors as one ``error: ...`` line (exit 2), like every other user error:
    the usage block of a command with 40 options buried the line that says what is wrong."""

    def error(self, message: str):
        self.exit(2, f"error: {self.prog}: {message} (see '{self.prog} --help')\n")


def _parser(argv: list[str] | None = None) -> argparse.ArgumentParser:

    ap = OneLineParser(prog="ipf-jax", description="Markerless 3D motion capture and gait "
                       "analysis by Interval Particle Filtering (JAX).")
    ap.add_argument("--version", action="version", version=f"ipf-jax {__version__}")
    ap.add_argument("--debug", action="store_true",
                    help="show the full traceback of an internal error (a bug) instead of one line")
    sub = ap.add_subparsers(dest="command", required=True)

    _add_module_commands(sub, sys.argv[1:] if argv is None else argv)
    return ap


def main(argv: list[str] | None = None) -> int:
    ap = _parser(argv)
    args = ap.parse_args(argv)
    warnings.showwarning = _show_warning
    stop.clear()  # a stop left over from an earlier command in this process is not this one's
    previous = _on_sigterm()
    try:
        from .. import jax_setup

        jax_setup.configure()
        _refuse_empty_paths(args)
        return args.func(args)
    except IPFError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    except stop.Terminated:
        print("terminated (rows written so far are kept; rerun with --resume)", file=sys.stderr)
        return 128 + signal.SIGTERM
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
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)
        stop.clear()


def _raise_terminated(signum, frame):
    stop.request()  # recorded as well: loops check it, should this exception be lost


def _on_sigterm():
    """SIGTERM raises :class:`~ipf_jax.stop.Terminated` while a command runs (main thread only); returns the
    handler to put back, or None when it cannot be set here."""
    if threading.current_thread() is not threading.main_thread():
        return None
    return signal.signal(signal.SIGTERM, _raise_terminated)


def _refuse_empty_paths(args: argparse.Namespace) -> None:
    """``--out ""`` (or ``--json ""``) would write into the current folder: refused."""
    for name in ("out", "json"):
        value = getattr(args, name, None)
        if isinstance(value, str) and not value.strip():
            raise IPFError(f"--{name} is empty: give a folder or file name")


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
