"""Cameras from a calibration board: intrinsics from several views per camera, extrinsics from a
still board on the floor (the world frame) or, for cameras without one, from views shared with an
already placed camera (stereo pairs, chained). ``ipf-jax calibrate`` (:mod:`ipf_jax.cli.calibrate`)
is the command; the board detection and OpenCV fits are :mod:`.checkerboard`.
"""
from __future__ import annotations

import itertools
from typing import NamedTuple

import numpy as np

from ..errors import IPFError, require
from ..geometry.camera import Camera, validate_camera
from . import checkerboard as cb


class Request(NamedTuple):
    """What to calibrate: per camera name, board views for intrinsics (``sources``), known
    intrinsics files (``known``), a still floor board (``floors``); ``flip`` cameras number their
    floor board from the other end; ``size`` (W, H) when only intrinsics files are given."""

    sources: dict
    known: dict
    floors: dict
    flip: tuple = ()
    size: tuple | None = None


def calibrate_cameras(board: "cb.Board", req: Request, *, max_error: float,
                      where: str = "") -> tuple[dict, list[str]]:
    """The cameras.json document (with each camera's reprojection error) and summary lines.

    A camera whose error exceeds ``max_error`` px is an IPFError (nothing is returned).
    """
    names = list(dict.fromkeys([*req.sources, *req.known, *req.floors]))
    require(bool(names), "give at least one --camera or --intrinsics")
    bad = [n for n in req.flip if n not in req.floors]
    require(not bad, f"--flip {', '.join(bad)}: no --floor for that camera")
    views, sizes, intr, floor_views, notes = _intrinsics(board, req, names)
    poses, pose_err, how, flip_notes = _floor_poses(board, req, floor_views, intr)
    notes += flip_notes
    if not poses:  # no floor board: the first camera is the world
        poses[names[0]], pose_err[names[0]], how[names[0]] = (np.eye(3), np.zeros(3)), 0.0, "world"
    _chain(board, names, views, sizes, intr, poses, pose_err, how)
    entries = []
    for n in names:
        entry, note = _entry(n, poses[n], sizes[n], intr[n], pose_err[n], how[n], max_error, where)
        entries.append(entry)
        notes.append(note)
    if board.symmetric and len(floor_views) > 1:
        notes.append(f"note: a {board.cols}x{board.rows} chessboard looks the same after a half "
                     "turn: check that the camera centres above are where the cameras stand "
                     "(--flip NAME numbers a camera's board from the other end)")
    doc = {"format": "ipf-jax-cameras", "version": 1, "units": "m",
           "board": {"cols": board.cols, "rows": board.rows, "square_m": board.square,
                     "charuco": board.charuco}, "cameras": entries}
    return doc, notes


def _intrinsics(board, req: Request, names):
    notes, views, sizes, intr, floor_views = [], {}, {}, {}, {}
    for n in names:
        if n in req.sources:
            views[n], sizes[n] = cb.views(req.sources[n], board)
        if n in req.floors:
            floor_views[n], size = cb.still_view(req.floors[n], board)
            sizes.setdefault(n, size)
        if n not in sizes:
            require(req.size is not None, f"camera {n}: give --size WxH (no image of it)")
            sizes[n] = req.size
        if n in req.known:
            intr[n] = cb.read_intrinsics(req.known[n], *sizes[n])
        else:
            require(n in views, f"camera {n}: give --camera {n}=VIEWS or --intrinsics {n}=FILE")
            intr[n] = cb.intrinsics(views[n], sizes[n], board)
            notes.append(f"{n}: intrinsics from {intr[n].used} views, {intr[n].rms:.3f} px")
    return views, sizes, intr, floor_views, notes


def _floor_pose(board, v, intr, flip: bool):
    """(R, t, rms) of one camera from its still floor board, numbered from the other end if
    ``flip``."""
    if flip:
        v = v._replace(uv=v.uv[::-1].copy())
    R, t, rms, _ = cb.board_pose([v], intr.K, intr.dist, board)
    if (-R.T @ t)[2] > 0 and not board.charuco:
        # numbered with the other handedness: the board's z would point at this camera
        # (every camera must stand on one side of the floor); a mirror of a pattern that
        # has an odd number of squares along that side numbers the same squares
        mirrored = cb.mirrored(v, board)
        if mirrored is not None:
            R, t, rms, _ = cb.board_pose([mirrored], intr.K, intr.dist, board)
    return R, t, rms


def _floor_poses(board, req: Request, floor_views, intr):
    flips = {n: n in req.flip for n in floor_views}
    notes = []
    if board.symmetric and not req.flip:
        flips, notes = _flips_from_layout(board, floor_views, intr)
    poses, pose_err, how = {}, {}, {}
    for n, v in floor_views.items():
        R, t, rms = _floor_pose(board, v, intr[n], flips[n])
        poses[n], pose_err[n], how[n] = (R, t), rms, "floor board"
    return poses, pose_err, how, notes


#: Pairwise camera distances must agree with the files' layout this much better (spread of their
#: log ratios) before the board numbering is changed on the strength of it.
LAYOUT_GAIN = 3.0


def _flips_from_layout(board, floor_views, intr) -> tuple[dict, list[str]]:
    """The board numbering of each floor camera that makes the camera layout agree with the
    poses their ``--intrinsics`` files hold (uu's ``config.xml``), when three or more have one.

    A half turn of a symmetric chessboard moves a camera's centre to the other side of the board;
    distances between camera centres do not depend on the world frame or its units, so the
    numbering whose pairwise distances are one scale of the files' is the right one. Renumbering
    all the checked cameras turns their world, not their layout, so of a choice and its opposite
    the one that renumbers fewer is taken: most detections are taken to be right, as the
    numbering of a camera whose file holds no pose (never renumbered: the layout cannot check it)
    must be."""
    names = list(floor_views)
    flips = {n: False for n in names}
    known = [n for n in names if intr[n].centre is not None]
    if len(known) < 3:
        return flips, []
    centres = {(n, f): -R.T @ t for n in known for f in (False, True)
               for R, t, _ in [_floor_pose(board, floor_views[n], intr[n], f)]}
    pairs = list(itertools.combinations(known, 2))

    def log_ratios(choice):
        return np.array([np.log(np.linalg.norm(intr[a].centre - intr[b].centre)
                                / max(np.linalg.norm(centres[a, choice[a]] - centres[b, choice[b]]), 1e-9))
                         for a, b in pairs])

    options = [dict(zip(known, (False, *rest))) for rest in itertools.product((False, True),
                                                                             repeat=len(known) - 1)]
    spread = [float(np.std(log_ratios(c))) for c in options]
    best = int(np.argmin(spread))
    if options[best] == options[0] or spread[best] * LAYOUT_GAIN > spread[0]:
        return flips, []
    chosen = {n: options[best].get(n, False) for n in names}
    opposite = {n: (not chosen[n]) if n in known else False for n in names}
    if sum(opposite.values()) < sum(chosen.values()):
        chosen = opposite
    flips.update(chosen)
    ratio, first = np.exp(log_ratios(options[best])), np.exp(log_ratios(options[0]))
    turned = [n for n in names if chosen[n]]
    notes = [f"{', '.join(turned)}: floor board numbered from the other end, so that the camera "
             f"layout agrees with the poses in the --intrinsics files (their camera distances are "
             f"{ratio.min():.2f}-{ratio.max():.2f}x these, {first.min():.2f}-{first.max():.2f}x "
             "with the first numbering)"]
    scale = float(np.exp(np.median(np.log(ratio))))
    if 0.5 < scale < 2.0 and abs(scale - 1.0) > 0.1:
        notes.append(f"note: the --intrinsics files place the cameras {scale:.2f}x as far apart as "
                     f"this board does: if they are right, the board's squares are "
                     f"{board.square * scale:.4g} m, not {board.square:g} m (--square)")
    return flips, notes


def _chain(board, names, views, sizes, intr, poses, pose_err, how) -> None:
    """Place the remaining cameras from board views shared with a placed one (in place)."""
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


def _entry(n, pose, size, intr, pose_err, how, max_error, where):
    R, t = pose
    w, h = size
    cam = validate_camera(Camera(K=intr.K, dist=intr.dist, R=R, T=t, width=w, height=h, name=n),
                          where)
    errs = {"intrinsics": None if np.isnan(intr.rms) else round(intr.rms, 4),
            "extrinsics": round(pose_err, 4)}
    worst = max(v for v in errs.values() if v is not None)
    require(worst <= max_error, f"camera {n}: reprojection error {worst:.2f} px exceeds "
            f"--max-error {max_error:g} px (more views of the board, sharper images, or "
            "a larger board)")
    note = (f"{n}: extrinsics from the {how}, {pose_err:.3f} px; centre "
            f"{np.round(cam.centre, 3).tolist()} m")
    entry = {"name": n, "width": w, "height": h, "K": cam.K.tolist(), "dist": cam.dist.tolist(),
             "R": cam.R.tolist(), "T": cam.T.tolist(), "reprojection_error_px": errs,
             "extrinsics_from": how}
    return entry, note
