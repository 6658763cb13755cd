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
import sys
from pathlib import Path

import numpy as np

from .errors import IPFError, require


def _pairs(values, flag: str) -> list[tuple[str, str]]:
    out = []
    for v in values or []:
        name, sep, src = v.partition("=")
        require(bool(sep and name and src), f"{flag} must be NAME=SOURCE, got {v!r}")
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
    p.add_argument("--camera", action="append", metavar="NAME=SOURCE",
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
                        "the same after a half turn)")
    p.add_argument("--size", metavar="WxH", help="image size when only --intrinsics are given")
    p.add_argument("--max-error", type=float, default=1.0,
                   help="refuse a camera whose reprojection error exceeds this, px (default 1)")
    p.add_argument("--out", required=True, metavar="FILE", help="cameras.json to write")
    p.set_defaults(func=run)
    return p


def calibrate(args) -> tuple[dict, list[str]]:
    """The cameras.json document and summary lines (the library side of the command)."""
    from . import checkerboard as cb
    from .camera import Camera, validate_camera

    board = cb.parse_board(args.board, args.square, charuco=args.charuco, marker=args.marker,
                           dictionary=args.dictionary)
    sources = dict(_pairs(args.camera, "--camera"))
    known = dict(_pairs(args.intrinsics, "--intrinsics"))
    floors = dict(_pairs(args.floor, "--floor"))
    names = list(dict.fromkeys([*sources, *known, *floors]))
    require(bool(names), "give at least one --camera or --intrinsics")
    bad = [n for n in args.flip if n not in floors]
    require(not bad, f"--flip {', '.join(bad)}: no --floor for that camera")
    notes, views, sizes, intr, floor_views = [], {}, {}, {}, {}
    for n in names:
        if n in sources:
            views[n], sizes[n] = cb.views(sources[n], board)
        if n in floors:
            floor_views[n], size = cb.still_view(floors[n], board)
            sizes.setdefault(n, size)
        if n not in sizes:
            require(args.size is not None, f"camera {n}: give --size WxH (no image of it)")
            sizes[n] = tuple(int(v) for v in args.size.lower().split("x"))
        if n in known:
            intr[n] = cb.read_intrinsics(known[n], *sizes[n])
        else:
            require(n in views, f"camera {n}: give --camera {n}=VIEWS or --intrinsics {n}=FILE")
            intr[n] = cb.intrinsics(views[n], sizes[n], board)
            notes.append(f"{n}: intrinsics from {intr[n].used} views, {intr[n].rms:.3f} px")
    poses, pose_err, how = {}, {}, {}
    for n in names:
        if n in floor_views:
            v = floor_views[n]
            if n in args.flip:
                v = v._replace(uv=v.uv[::-1].copy())
            R, t, rms, _ = cb.board_pose([v], intr[n].K, intr[n].dist, board)
            if (-R.T @ t)[2] > 0 and not board.charuco:
                # numbered with the other handedness: the board's z would point at this camera
                # (every camera must stand on one side of the floor); a mirror of a pattern that
                # has an odd number of squares along that side numbers the same squares
                mirrored = cb.mirrored(v, board)
                if mirrored is not None:
                    R, t, rms, _ = cb.board_pose([mirrored], intr[n].K, intr[n].dist, board)
            poses[n], pose_err[n], how[n] = (R, t), rms, "floor board"
    if not poses:  # no floor board: the first camera is the world
        poses[names[0]], pose_err[names[0]], how[names[0]] = (np.eye(3), np.zeros(3)), 0.0, "world"
    while len(poses) < len(names):
        placed = False
        for n in (m for m in names if m not in poses):
            for ref in list(poses):
                if n not in views or ref not in views:
                    continue
                try:
                    Rr, tr, rms, count = cb.relative_pose(views[ref], views[n], intr[ref], intr[n],
                                                          sizes[n], board)
                except IPFError:
                    continue
                R0, t0 = poses[ref]
                poses[n] = (Rr @ R0, Rr @ t0 + tr)
                pose_err[n], how[n] = rms, f"pair with {ref} ({count} views)"
                placed = True
                break
        unplaced = [m for m in names if m not in poses]
        require(placed or not unplaced, f"camera(s) {', '.join(unplaced)}: no --floor board and "
                "no views shared with a placed camera")
    cams, entries = [], []
    for n in names:
        R, t = poses[n]
        w, h = sizes[n]
        cam = validate_camera(Camera(K=intr[n].K, dist=intr[n].dist, R=R, T=t, width=w, height=h,
                                     name=n), args.out)
        errs = {"intrinsics": None if np.isnan(intr[n].rms) else round(intr[n].rms, 4),
                "extrinsics": round(pose_err[n], 4)}
        worst = max(v for v in errs.values() if v is not None)
        require(worst <= args.max_error, f"camera {n}: reprojection error {worst:.2f} px exceeds "
                f"--max-error {args.max_error:g} px (more views of the board, sharper images, or "
                "a larger board)")
        notes.append(f"{n}: extrinsics from the {how[n]}, {pose_err[n]:.3f} px; centre "
                     f"{np.round(cam.centre, 3).tolist()} m")
        cams.append(cam)
        entries.append({"name": n, "width": w, "height": h, "K": cam.K.tolist(),
                        "dist": cam.dist.tolist(), "R": cam.R.tolist(), "T": cam.T.tolist(),
                        "reprojection_error_px": errs, "extrinsics_from": how[n]})
    if board.symmetric and len(floor_views) > 1:
        notes.append(f"note: a {board.cols}x{board.rows} chessboard looks the same after a half "
                     "turn: check that the camera centres above are where the cameras stand "
                     "(--flip NAME numbers a camera's board from the other end)")
    doc = {"format": "ipf-jax-cameras", "version": 1, "units": "m",
           "board": {"cols": board.cols, "rows": board.rows, "square_m": board.square,
                     "charuco": board.charuco}, "cameras": entries}
    return doc, notes


def run(args: argparse.Namespace) -> int:
    try:
        doc, notes = calibrate(args)
        out = Path(args.out)
        tmp = out.with_name(out.name + ".tmp")
        try:
            tmp.write_text(json.dumps(doc, indent=1) + "\n")
            tmp.replace(out)
        except OSError as e:
            tmp.unlink(missing_ok=True)
            raise IPFError(f"cannot write ({e.strerror or e})", out) from None
    except IPFError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    for line in notes:
        print(line)
    print(f"wrote {args.out} ({len(doc['cameras'])} cameras)")
    return 0
