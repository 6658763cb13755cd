"""``ipf-jax export RUN_DIR --format trc|c3d|bvh|csv --out FILE [--up AXIS] [--units m|cm|mm]``.

Thin over the library: read the run directory, call one exporter. Wire it into the main CLI with
:func:`add_parser` (it sets ``func=run``); :func:`main` runs it alone.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from ..analysis.export import smoothed
from ..analysis.export.axes import UNIT_SCALE
from ..analysis.export.bvh import export_bvh
from ..analysis.export.c3d import export_c3d
from ..analysis.export.joints_csv import export_csv
from ..analysis.export.trc import export_trc
from ..data import checkpoint
from ..data.rundir import read_run
from ..data.runfiles import check_output_file
from ..errors import IPFError, require
from ..geometry.world import AXES

#: format -> (exporter, default up axis (None = the run's world frame), default units)
EXPORTERS = {
    "trc": (export_trc, "+y", "mm"),
    "c3d": (export_c3d, None, "mm"),
    "bvh": (export_bvh, "+y", "m"),
    "csv": (export_csv, None, "m"),
}
from .options import add_common, add_option

#: what ``track`` writes in a run folder: never overwritten by an export
RUN_FILES = ("joints.csv", "poses.csv", "run.json", "shape.json", checkpoint.NAME, smoothed.NAME)


def add_parser(subparsers) -> argparse.ArgumentParser:
    """Add the ``export`` sub-command to an ``argparse`` sub-parser collection."""
    p = subparsers.add_parser(
        "export", help="write tracking results as TRC, C3D, BVH or CSV",
        description="Export a run directory (joints.csv, poses.csv, run.json) to OpenSim (TRC), "
                    "Mokka/Vicon (C3D), Blender (BVH) or CSV. See docs/export.md.")
    p.add_argument("run_dir", metavar="RUN_DIR", help="directory written by 'ipf-jax track'")
    p.add_argument("--format", choices=tuple(EXPORTERS),
                   help="output format (default: from the --out suffix)")
    add_common(p, "out", metavar="FILE", help="output file")
    add_option(p, "up_axis", help="up axis in the file, one of " + " ".join(AXES) + " (write "
               "--up=-z for a negative axis); default: +y for trc and bvh, the run's world frame "
               "for c3d and csv")
    add_common(p, "units", choices=tuple(UNIT_SCALE),
               help="length unit; default: mm for trc and c3d, m for bvh and csv")
    add_common(p, "smooth", help="export the joints low-passed by the gait analysis' zero-lag "
               "filter (5 Hz, at most fps/4; trc, c3d, csv); the run's files stay raw")
    p.set_defaults(func=run)
    return p


def run(args: argparse.Namespace) -> int:
    """Run ``export``; a user error prints one ``error: ...`` line on stderr and returns 2."""
    out = Path(args.out)
    fmt = args.format or out.suffix.lower().lstrip(".")
    try:
        if fmt not in EXPORTERS:
            raise IPFError(f"cannot tell the format from the suffix {out.suffix!r}; use --format "
                           f"({', '.join(EXPORTERS)})", out)
        named = out.suffix.lower().lstrip(".")
        require(named not in EXPORTERS or named == fmt, f"--format {fmt} but the file is named "
                f".{named}: a {fmt} file under another format's name (rename it or drop --format)", out)
        export, up, units = EXPORTERS[fmt]
        out = check_output_file(out)  # a folder or an unwritable place: said before any work
        run_data = read_run(args.run_dir)
        require(not (out.name in RUN_FILES and out.resolve().parent == run_data.path.resolve()),
                "is one of the run's own files: export to another name (the run is kept as it is)", out)
        require(bool(np.isfinite(run_data.joints).all(axis=(1, 2)).any()),
                "no tracked frame to export (every frame of the run is missing or lost)", args.run_dir)
        if args.smooth:
            if fmt == "bvh":
                raise IPFError("--smooth applies to the joints (trc, c3d, csv); bvh is written from "
                               "the poses", out)
            run_data = run_data._replace(joints=smoothed.smooth_joints(run_data)[0])
        export(run_data, out, up=args.up_axis or up, units=args.units or units)
        extra = []
        if fmt == "trc":  # OpenSim's marker set and IK setup for it (docs/export.md)
            from ..analysis.export.opensim import write_opensim_files

            t = run_data.time_s[np.isfinite(run_data.joints).all(axis=(1, 2))]
            t0, t1 = (float(t[0]), float(t[-1])) if len(t) else (0.0, 0.0)
            extra = write_opensim_files(out, t0, t1)
    except IPFError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    print(f"wrote {out} ({fmt}, {len(run_data.frames)} frames)")
    for path in extra:
        print(f"wrote {path}")
    return 0


def main(argv: list[str] | None = None) -> int:
    """Stand-alone entry: ``python -m ipf_jax.cli.export export RUN_DIR ...``."""
    parser = argparse.ArgumentParser(prog="ipf-jax")
    add_parser(parser.add_subparsers(dest="command", required=True))
    return run(parser.parse_args(argv))


if __name__ == "__main__":
    sys.exit(main())
