"""``ipf-jax init-dataset``: write a dataset.json for videos or image folders and a calibration."""
from __future__ import annotations

import argparse
from pathlib import Path

from ..errors import require
from ..geometry.world import AXES
from .options import add_common, add_option, check_args


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "init-dataset", help="write a dataset.json for videos or image folders and a calibration",
        description="Describe a recording for 'ipf-jax track': one video or folder of numbered "
                    "images per camera (or one folder holding them) and a calibration file. "
                    "Cameras are matched by the name in each file name, else by order. "
                    "See docs/formats.md.")
    p.add_argument("inputs", nargs="+", metavar="INPUT",
                   help="video files or image folders, one per camera (or one folder of them)")
    p.add_argument("--calibration", required=True, metavar="FILE",
                   help="any calibration ipf-jax reads (.qca.txt, .xcp, .mcal, .toml, .xml, ...)")
    add_common(p, "out", metavar="DIR", help="folder for dataset.json")
    p.add_argument("--names", help="comma-separated calibration camera names, in input order")
    add_common(p, "masks", help="the inputs are folders of masks")
    p.add_argument("--background", nargs="+", metavar="BG",
                   help="empty-room video, image or folder per camera (default: from the frames)")
    add_common(p, "units", choices=("m", "cm", "mm"),
                   help="translation units of an OpenCV or TOML calibration")
    add_option(p, "fps", help="frame rate (default: the videos')")
    add_option(p, "up_axis", help="world up axis, one of " + " ".join(AXES) + " (default: detected)")
    p.add_argument("--force", action="store_true", help="replace an existing dataset.json")
    p.set_defaults(func=run)
    return p


def run(args: argparse.Namespace) -> int:
    from ..data import init_dataset

    check_args(args)  # --fps and --up: their own rules before anything is written
    names = [n.strip() for n in args.names.split(",")] if args.names else None
    if names:
        twice = sorted({n for n in names if names.count(n) > 1})
        require(not twice, f"--names lists {', '.join(twice)} more than once: one camera per input")
    doc, notes = init_dataset.describe(
        [Path(p) for p in args.inputs], Path(args.calibration), Path(args.out), names=names,
        units=args.units, masks=args.masks,
        backgrounds=[Path(b) for b in args.background] if args.background else None,
        fps=args.fps, up_axis=args.up_axis)
    target = init_dataset.write(doc, Path(args.out), force=args.force)
    for line in notes:
        print(line)
    print(f"wrote {target}: track it with 'ipf-jax track {args.out} --out RUN'")
    return 0
