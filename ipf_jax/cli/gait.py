"""``ipf-jax gait INPUT --out DIR``: gait events and parameters from joints or marker files.

Thin over the library: :func:`ipf_jax.analysis.gait.io.load` -> :func:`ipf_jax.analysis.gait.analyse` ->
:func:`ipf_jax.analysis.gait.report.write_outputs`. :func:`add_parser` registers the sub-command on the main
CLI's sub-parsers; :func:`run` executes parsed arguments and returns the exit status (0 ok,
2 for a user-fixable problem, printed as one ``error: <file>: <problem>`` line on stderr).
"""
from __future__ import annotations

import argparse
import sys

from ..analysis.gait.events import DEFAULT_METHOD, METHODS
from ..analysis.gait.filtering import DEFAULT_CUTOFF_HZ
from ..analysis.gait.trajectories import UNIT_SCALE
from ..errors import IPFError
from .options import add_common, add_option


def add_parser(subparsers) -> argparse.ArgumentParser:
    """Add the ``gait`` sub-command to an ``argparse`` sub-parsers object; returns its parser."""
    p = subparsers.add_parser(
        "gait", help="gait events and parameters from joints.csv, .trc or .c3d",
        description="Detect heel strikes and toe-offs and measure spatio-temporal gait "
                    "parameters; writes gait.json, steps.csv, strides.csv, PNG plots and "
                    "report.html into --out.")
    p.add_argument("input", help="joints.csv (tracker output or same convention), .trc or .c3d")
    add_common(p, "out")
    p.add_argument("--marker-map", default=None,
                   help="JSON role -> marker name(s) for .trc/.c3d (default: recognise the "
                        "marker set: Plug-in Gait, Helen Hayes, Qualisys, Davis, Rajagopal, "
                        "ipf-jax)")
    p.add_argument("--method", choices=METHODS, default=DEFAULT_METHOD,
                   help=f"event detection method (default {DEFAULT_METHOD})")
    add_option(p, "up_axis", help="up axis of the input (default: run.json, else read from the body)")
    add_common(p, "units", choices=tuple(UNIT_SCALE), default=None,
               help="units of the input coordinates (default: as the file says)")
    p.add_argument("--cutoff", type=float, default=DEFAULT_CUTOFF_HZ,
                   help=f"low-pass cut-off in Hz (default {DEFAULT_CUTOFF_HZ:g}; at most fps/4)")
    add_common(p, "cameras", type=int, default=None,
               help="number of cameras that made the input (default: run.json's list; with 1, "
                    "step width is reported as not observable)")
    p.set_defaults(func=run)
    return p


def run(args: argparse.Namespace) -> int:
    """Run the analysis for parsed ``args``; returns the process exit status."""
    from ..analysis.gait.analysis import analyse
    from ..analysis.gait.io import load
    from ..analysis.gait.report import write_outputs

    try:
        traj = load(args.input, marker_map=args.marker_map, up=args.up_axis, units=args.units,
                    cameras=args.cameras)
        result = analyse(traj, method=args.method, cutoff_hz=args.cutoff)
        files = write_outputs(result, args.out)
    except IPFError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    n_hs = sum(len(result.events[f"{s}_heel_strike"]) for s in ("left", "right"))
    lab = result.lab
    speed = result.fall_risk["walking_speed_m_s"]["value"]
    cadence = lab["cadence_steps_per_min"]
    print(f"{result.method} events: {n_hs} heel strikes, {len(result.steps)} steps"
          + (f", cadence {cadence:.1f} steps/min ({lab['steps']} steps in {lab['time_s']:.2f} s)"
             if cadence is not None else "")
          + (f", speed {speed:.2f} m/s" if speed is not None else "")
          + (f"; {len(result.rejected)} rejected (physiological bounds)" if result.rejected
             else "")
          + (f"; not observable: {', '.join(result.unobservable)}" if result.unobservable
             else "")
          + f"; {len(result.missing)} values not computed (see gait.json 'missing')"
          + f"; wrote {', '.join(files)} to {args.out}")
    return 0


def main(argv: list | None = None) -> int:
    """Stand-alone entry (``python -m ipf_jax.cli.gait``) until the main CLI wires ``gait`` in."""
    parser = argparse.ArgumentParser(prog="ipf-jax")
    add_parser(parser.add_subparsers(dest="command", required=True))
    args = parser.parse_args(argv)
    return args.func(args)


if __name__ == "__main__":
    sys.exit(main())
