"""``ipf-jax calibrate``: cameras.json from checkerboard/ChArUco images or videos.

Intrinsics come from several views of a board per camera (``--camera NAME=SOURCE``) or from a
file (``--intrinsics NAME=FILE``); extrinsics from a still board on the floor that defines the
world frame (``--floor NAME=SOURCE``: origin at its first corner, z along the board's normal), or
for cameras without one, from views shared with an already placed camera (stereo pairs, chained).
Every camera's reprojection error is written to cameras.json; a fit worse than ``--max-error``
pixels is refused and nothing is written. See docs/formats.md (Calibrating cameras).
"""
from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

from ..data.runfiles import check_output_file
from ..errors import IPFError, require
from .options import add_common, flag


def _pairs(values, flag: str) -> list[tuple[str, str]]:
    out = []
    for v in values or []:
        name, sep, src = v.partition("=")
        require(bool(sep and name and src), f"{flag} must be NAME=SOURCE, got {v!r}")
        require(name not in dict(out), f"{flag} {name} given twice (one {flag} per camera)")
        out.append((name, src))
    return out


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "calibrate", help="camera calibration from checkerboard/ChArUco images or videos",
        description="Calibrate cameras from a checkerboard or ChArUco board and write an ipf-jax "
                    "cameras.json with each camera's reprojection error. See docs/formats.md.")
    p.add_argument("--board", required=True, metavar="COLSxROWS",
                   help="inner corners of a chessboard (9x6), or squares of a ChArUco board")
    p.add_argument("--square", type=float, required=True, help="square side in metres (0.115)")
    p.add_argument("--charuco", action="store_true", help="a ChArUco board")
    p.add_argument("--marker", type=float, help="ChArUco marker side in metres (default 0.7 square)")
    p.add_argument("--dictionary", default="DICT_4X4_50", help="ChArUco ArUco dictionary")
    add_common(p, "camera", action="append", metavar="NAME=SOURCE",
                   help="views of the board for this camera's intrinsics: an image glob "
                        "('left*.jpg'), a folder of images or a video; repeat per camera")
    p.add_argument("--intrinsics", action="append", metavar="NAME=FILE",
                   help="known intrinsics instead (any calibration file, or an OpenCV file with "
                        "CameraMatrix and DistortionCoeffs)")
    p.add_argument("--floor", action="append", metavar="NAME=SOURCE",
                   help="a still board on the floor seen by this camera (image or video): the "
                        "world frame")
    p.add_argument("--flip", action="append", default=[], metavar="NAME",
                   help="number this camera's floor board from the other end (a board that looks "
                        "the same after a half turn); given, the numbering is no longer chosen "
                        "from the --intrinsics files' camera layout")
    add_common(p, "size", metavar="WxH", help="image size when only --intrinsics are given")
    p.add_argument("--max-error", type=float, default=1.0,
                   help="refuse a camera whose reprojection error exceeds this, px (default 1)")
    add_common(p, "out", metavar="FILE", help="cameras.json to write")
    p.set_defaults(func=run)
    return p


def _size(text: str) -> tuple[int, int]:
    """``"640x480"`` -> (640, 480); one error line for anything else."""
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise IPFError(f"--size must look like WIDTHxHEIGHT in pixels (e.g. 640x480), got {text!r}") from None
    require(w > 0 and h > 0, f"--size must be positive pixels, got {text!r}")
    return w, h


def calibrate(args) -> tuple[dict, list[str]]:
    """The cameras.json document and summary lines of the command line's request."""
    from ..data import checkerboard as cb
    from ..data.board_calibration import Request, calibrate_cameras

    board = cb.parse_board(args.board, args.square, charuco=args.charuco, marker=args.marker,
                           dictionary=args.dictionary)
    size = _size(args.size) if args.size else None
    req = Request(dict(_pairs(args.camera, flag("camera"))), dict(_pairs(args.intrinsics, "--intrinsics")),
                  dict(_pairs(args.floor, "--floor")), tuple(args.flip), size)
    return calibrate_cameras(board, req, max_error=args.max_error, where=args.out)


def run(args: argparse.Namespace) -> int:
    require(math.isfinite(args.max_error) and args.max_error > 0,
            f"--max-error must be a positive number of pixels, got {args.max_error}")
    out = check_output_file(Path(args.out))  # before the calibration, not after it
    doc, notes = calibrate(args)
    tmp = out.with_name(out.name + ".tmp")
    try:  # whole or not at all: a refused fit above wrote nothing
        out.parent.mkdir(parents=True, exist_ok=True)
        tmp.write_text(json.dumps(doc, indent=1) + "\n")
        tmp.replace(out)
    except OSError as e:
        tmp.unlink(missing_ok=True)
        raise IPFError(f"cannot write ({e.strerror or e})", out) from None
    for line in notes:
        print(line)
    print(f"wrote {args.out} ({len(doc['cameras'])} cameras)")
    return 0
