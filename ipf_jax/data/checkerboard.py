"""Camera calibration from a checkerboard or ChArUco board (OpenCV), for ``ipf-jax calibrate``.

* :func:`detect`: the board's inner corners in one image. Chessboards go through OpenCV's
  sector-based detector (then the classic one, then both on a 2x image); a small, oblique board on
  a floor, as a camera high in a room sees it, often defeats them all, so the last resort finds the
  white board (bright, unsaturated, ringed by the floor, holding dark squares), rectifies it to a
  fronto-parallel view and detects there.
* :func:`views`: detections over an image glob, a folder or a video (frames sampled evenly).
* :func:`intrinsics`: ``cv2.calibrateCamera`` over the views; :func:`board_pose`: a static board's
  pose (detections of a still clip averaged first); :func:`relative_pose`: a stereo pair's pose
  from synchronised views (``cv2.stereoCalibrate`` with the intrinsics fixed).

Every error is the root-mean-square distance in pixels between the detected corners and the
board's corners projected with the fitted camera.

A chessboard whose square counts are both odd (e.g. 8 x 6 inner corners) looks the same after a
half turn: each camera's numbering of its corners may then start at either end, and so the world
frame a floor board gives each camera is fixed only up to that half turn (:data:`SYMMETRIC`).
A ChArUco board, or a board with an even number of squares along one side, has no such ambiguity.
"""
from __future__ import annotations

import glob
from pathlib import Path
from typing import NamedTuple

import cv2
import numpy as np

from ..errors import IPFError, require
from .video import VideoReader

MAX_VIEWS = 40  # views used for intrinsics: more adds time, not accuracy
_IMAGE_EXT = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff")
_SB = cv2.CALIB_CB_NORMALIZE_IMAGE | cv2.CALIB_CB_EXHAUSTIVE | cv2.CALIB_CB_ACCURACY
_CLASSIC = cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE
_SUBPIX = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_COUNT, 50, 1e-3)


class Board(NamedTuple):
    """cols x rows inner corners (chessboard) or squares (ChArUco); square side in metres."""

    cols: int
    rows: int
    square: float = 1.0
    charuco: bool = False
    marker: float = 0.0  # ChArUco marker side, metres
    dictionary: str = "DICT_4X4_50"

    def object_points(self) -> np.ndarray:
        """(N, 3) float32 board corners in the board frame (z = 0), row by row."""
        n = (self.cols - 1, self.rows - 1) if self.charuco else (self.cols, self.rows)
        pts = np.zeros((n[0] * n[1], 3), np.float32)
        pts[:, :2] = np.mgrid[0:n[0], 0:n[1]].T.reshape(-1, 2) * self.square
        return pts

    @property
    def symmetric(self) -> bool:
        """Whether a half turn maps the chessboard pattern onto itself (see module doc)."""
        return not self.charuco and self.cols % 2 == 0 and self.rows % 2 == 0


class View(NamedTuple):
    """One image's detection: ``ids`` (M,) index into :meth:`Board.object_points`, ``uv`` (M, 2)."""

    name: str
    ids: np.ndarray
    uv: np.ndarray


def parse_board(text: str, square: float, *, charuco: bool = False, marker: float | None = None,
                dictionary: str = "DICT_4X4_50") -> Board:
    """``"9x6"`` -> Board; IPFError for anything else."""
    try:
        cols, rows = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise IPFError(f"--board must look like COLSxROWS (e.g. 9x6), got {text!r}") from None
    require(2 <= cols <= 100 and 2 <= rows <= 100, f"--board {text}: 2..100 corners a side")
    require(0 < square < np.inf, f"--square must be positive and finite, got {square:g}")
    if charuco:
        require(hasattr(cv2.aruco, dictionary), f"unknown ArUco dictionary {dictionary!r}")
        require(marker is None or 0 < marker < square,
                f"--marker must be positive and smaller than --square ({square:g}), got {marker:g}")
    return Board(cols, rows, float(square), charuco, float(marker or 0.7 * square), dictionary)


def _gray(image: np.ndarray) -> np.ndarray:
    return image if image.ndim == 2 else cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)


def _chessboard(gray: np.ndarray, pattern) -> np.ndarray | None:
    ok, c = cv2.findChessboardCornersSB(gray, pattern, flags=_SB)
    if ok:
        return c.reshape(-1, 2)
    ok, c = cv2.findChessboardCorners(gray, pattern, flags=_CLASSIC)
    if ok:
        return cv2.cornerSubPix(gray, c, (5, 5), (-1, -1), _SUBPIX).reshape(-1, 2)
    return None


def _paper_quad(image: np.ndarray) -> np.ndarray | None:
    """The 4 corners (4, 2) of a white board lying on a coloured floor, or None."""
    hsv = cv2.cvtColor(image, cv2.COLOR_BGR2HSV)
    white = ((hsv[..., 1] < 70) & (hsv[..., 2] > 180)).astype(np.uint8)
    contours, _ = cv2.findContours(white, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    best, best_dark = None, 0.1
    for c in contours:
        if cv2.contourArea(c) < 200:
            continue
        filled = np.zeros(white.shape, np.uint8)
        cv2.drawContours(filled, [c], -1, 1, -1)
        ring = (cv2.dilate(filled, np.ones((5, 5), np.uint8)) - filled) > 0
        floor = (hsv[..., 1][ring] > 90).mean()  # ringed by a saturated floor, not a wall
        dark = (hsv[..., 2][filled > 0] < 150).mean()  # holding the dark squares
        if floor > 0.3 and dark > best_dark:
            best, best_dark = c, dark
    if best is None:
        return None
    hull = cv2.convexHull(best)
    for eps in np.linspace(0.005, 0.15, 60):
        quad = cv2.approxPolyDP(hull, eps * cv2.arcLength(hull, True), True)
        if len(quad) == 4:
            q = quad.reshape(4, 2).astype(np.float32)
            c = q.mean(0)
            return q[np.argsort(np.arctan2(q[:, 1] - c[1], q[:, 0] - c[0]))]
    return None


def _rectified(image: np.ndarray, board: Board, px: int = 40) -> np.ndarray | None:
    """Corners found in a fronto-parallel view of the white board, mapped back (N, 2)."""
    quad = _paper_quad(image)
    if quad is None:
        return None
    gray = _gray(image)
    for nx, ny in ((board.cols + 1, board.rows + 1), (board.rows + 1, board.cols + 1)):
        W, H = (nx + 3) * px, (ny + 3) * px
        dst = np.array([[px / 2, px / 2], [W - px / 2, px / 2], [W - px / 2, H - px / 2],
                        [px / 2, H - px / 2]], np.float32)
        Hm = cv2.getPerspectiveTransform(quad, dst)
        warped = cv2.warpPerspective(gray, Hm, (W, H), flags=cv2.INTER_CUBIC, borderValue=255)
        found = _chessboard(warped, (nx - 1, ny - 1))
        if found is None:
            continue
        back = cv2.perspectiveTransform(found.reshape(-1, 1, 2), np.linalg.inv(Hm)).reshape(-1, 2)
        if nx - 1 != board.cols:  # found as rows x cols: back to cols x rows, row by row
            back = back.reshape(board.cols, board.rows, 2).transpose(1, 0, 2).reshape(-1, 2)
        return back.astype(np.float32)
    return None


def detect(image: np.ndarray, board: Board) -> tuple[np.ndarray, np.ndarray] | None:
    """(ids (M,), uv (M, 2) pixels) of the board in one image, or None (see module doc)."""
    gray = _gray(image)
    if board.charuco:
        dic = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, board.dictionary))
        cb = cv2.aruco.CharucoBoard((board.cols, board.rows), board.square, board.marker, dic)
        corners, ids, _, _ = cv2.aruco.CharucoDetector(cb).detectBoard(gray)
        if ids is None or len(ids) < 6:
            return None
        return ids.ravel().astype(int), corners.reshape(-1, 2).astype(np.float32)
    pattern = (board.cols, board.rows)
    uv = _chessboard(gray, pattern)
    if uv is None:  # small boards: a 2x image helps both detectors
        big = cv2.resize(gray, None, fx=2, fy=2, interpolation=cv2.INTER_CUBIC)
        uv = _chessboard(big, pattern)
        uv = None if uv is None else (uv + 0.5) / 2 - 0.5
    if uv is None and image.ndim == 3:
        uv = _rectified(image, board)
    if uv is None:
        return None
    return np.arange(len(uv)), uv.astype(np.float32)


def _frames(source: str, max_frames: int):
    """(name, image) pairs of an image glob, a folder of images or a video (sampled)."""
    path = Path(source)
    if path.is_file() and path.suffix.lower() not in _IMAGE_EXT:
        reader = VideoReader(path)
        idx = np.unique(np.linspace(0, reader.frame_count - 1,
                                    min(reader.frame_count, max_frames)).round().astype(int))
        for i, frame in reader.frames(idx):
            yield f"{path.name}#{i}", frame
        reader.close()
        return
    files = sorted(p for p in path.iterdir() if p.suffix.lower() in _IMAGE_EXT) if path.is_dir() \
        else sorted(Path(p) for p in glob.glob(source))
    require(bool(files), "no images or video found (an image glob, a folder or a video)", source)
    for f in files:
        image = cv2.imread(str(f), cv2.IMREAD_COLOR)
        require(image is not None, "not a readable image", f)
        yield f.name, image


def views(source: str, board: Board, max_frames: int = 4 * MAX_VIEWS
          ) -> tuple[list[View], tuple[int, int]]:
    """Every detection in ``source`` (a video: ``max_frames`` sampled evenly) and the image size
    (W, H)."""
    out, size = [], None
    for name, image in _frames(source, max_frames):
        h, w = image.shape[:2]
        require(size in (None, (w, h)), f"image {name} is {w}x{h}, the first is "
                f"{size[0]}x{size[1]}" if size else "", source)
        size = (w, h)
        found = detect(image, board)
        if found is not None:
            out.append(View(name, *found))
    require(size is not None, "no frames", source)
    return out, size


def still_view(source: str, board: Board, frames: int = 32) -> tuple[View, tuple[int, int]]:
    """The board of a clip (or image) of a still board: detected once on the mean of ``frames``
    frames, whose averaging lowers the noise and compression artefacts the corners sit in."""
    images = [im.astype(np.float32) for _, im in _frames(source, frames)]
    require(bool(images), "no frames", source)
    mean = np.mean(images, 0).round().astype(np.uint8)
    found = detect(mean, board)
    require(found is not None, f"the {board.cols}x{board.rows} board was not found (in the mean "
            f"of {len(images)} frames)", source)
    return View(f"mean of {len(images)} frames", *found), (mean.shape[1], mean.shape[0])


def read_intrinsics(path: str | Path, width: int, height: int) -> Intrinsics:
    """K and distortion from any calibration file ipf-jax reads, or an OpenCV file holding only
    a camera matrix and distortion (``intrinsics.xml``; the XML header may be missing)."""
    from .calibration import read_calibration

    path = Path(path)
    try:
        cam = read_calibration(path, width, height)[0]
        posed = not (np.allclose(cam.R, np.eye(3)) and np.allclose(cam.T, 0.0))
        return Intrinsics(cam.K, cam.dist, float("nan"), 0, cam.centre if posed else None)
    except IPFError as e:
        if "missing" not in e.message and "OpenCV" not in e.message:
            raise
    text = path.read_text(errors="replace").lstrip()
    if text.startswith("<") and not text.startswith("<?xml"):
        text = '<?xml version="1.0"?>\n' + text
    try:
        fs = cv2.FileStorage(text, cv2.FILE_STORAGE_READ | cv2.FILE_STORAGE_MEMORY)
        K = next(n.mat() for n in map(fs.getNode, ("CameraMatrix", "camera_matrix", "K"))
                 if not n.empty())
        dist = next(n.mat() for n in map(fs.getNode, ("DistortionCoeffs",
                                                      "distortion_coefficients", "D"))
                    if not n.empty())
    except (cv2.error, SystemError, StopIteration):
        raise IPFError("no CameraMatrix and DistortionCoeffs in this file", path) from None
    d = np.zeros(5)
    d[:min(5, dist.size)] = np.asarray(dist, float).ravel()[:5]
    require(np.asarray(K).shape == (3, 3) and np.all(np.isfinite(K)) and np.all(np.isfinite(d)),
            "CameraMatrix must be a finite 3x3 matrix", path)
    return Intrinsics(np.asarray(K, float), d, float("nan"), 0)


def _rms(board: Board, view: View, rvec, tvec, K, dist) -> float:
    uv, _ = cv2.projectPoints(board.object_points()[view.ids], rvec, tvec, K, dist)
    return float(np.sqrt(((uv.reshape(-1, 2) - view.uv) ** 2).sum(1).mean()))


class Intrinsics(NamedTuple):
    K: np.ndarray  # (3, 3)
    dist: np.ndarray  # (5,) k1 k2 p1 p2 k3
    rms: float  # px over every corner of every view used
    used: int  # views used
    centre: np.ndarray | None = None  # (3,) camera centre of the file's own pose, when it has one


def intrinsics(found: list[View], size: tuple[int, int], board: Board) -> Intrinsics:
    """``cv2.calibrateCamera`` over at most :data:`MAX_VIEWS` views spread over ``found``."""
    require(len(found) >= 3, f"the board was found in {len(found)} image(s): intrinsics need at "
            "least 3 views of it in different poses")
    pick = [found[int(i)] for i in np.unique(np.linspace(0, len(found) - 1,
                                                         min(len(found), MAX_VIEWS)).round())]
    obj = [board.object_points()[v.ids] for v in pick]
    img = [v.uv.reshape(-1, 1, 2) for v in pick]
    flags = 0 if len(pick) >= 10 else cv2.CALIB_FIX_K3  # k3 overfits a handful of views
    rms, K, dist, _, _ = cv2.calibrateCamera(obj, img, size, None, None, flags=flags)
    return Intrinsics(K, dist.ravel()[:5], float(rms), len(pick))


def board_pose(found: list[View], K: np.ndarray, dist: np.ndarray, board: Board,
               *, max_spread: float = 1.5):
    """(R (3, 3), t (3,), rms px, view) of a still board: detections averaged, then PnP + LM."""
    require(bool(found), "the board was not found in any frame")
    full = [v for v in found if len(v.ids) == len(found[0].ids)
            and np.array_equal(v.ids, found[0].ids)]
    uv = np.stack([v.uv for v in full])  # (F, N, 2)
    mean = uv.mean(0)
    # a numbering that starts at the other end in some frames is turned back first
    flip = np.abs(uv[:, ::-1] - mean[::-1]).mean((1, 2)) < np.abs(uv - mean).mean((1, 2))
    if flip.any() and not flip.all() and board.symmetric:
        uv[flip] = uv[flip][:, ::-1]
        mean = uv.mean(0)
    spread = float(np.abs(uv - mean).max())
    require(spread <= max_spread, f"the board moves during the clip (corners spread {spread:.1f} "
            f"px > {max_spread} px): give a clip of a still board")
    view = View(f"mean of {len(full)} frames", full[0].ids, mean.astype(np.float32))
    obj = board.object_points()[view.ids]
    ok, rvec, tvec = cv2.solvePnP(obj, view.uv, K, dist, flags=cv2.SOLVEPNP_ITERATIVE)
    require(ok, "the board pose could not be solved")
    rvec, tvec = cv2.solvePnPRefineLM(obj, view.uv, K, dist, rvec, tvec)
    return cv2.Rodrigues(rvec)[0], tvec.ravel(), _rms(board, view, rvec, tvec, K, dist), view


def relative_pose(views_a: list[View], views_b: list[View], cam_a: Intrinsics, cam_b: Intrinsics,
                  size: tuple[int, int], board: Board):
    """(R, t, rms px) of camera b relative to camera a from views with the same names."""
    b_by = {v.name.split("#")[-1] if "#" in v.name else _index(v.name): v for v in views_b}
    pairs = []
    for va in views_a:
        key = va.name.split("#")[-1] if "#" in va.name else _index(va.name)
        vb = b_by.get(key)
        if vb is not None:
            common = np.intersect1d(va.ids, vb.ids)
            if len(common) >= 6:
                ia, ib = (np.searchsorted(v.ids, common) for v in (va, vb))
                pairs.append((board.object_points()[common], va.uv[ia], vb.uv[ib]))
    require(len(pairs) >= 1, "no image in which both cameras of the pair see the board (views "
            "are paired by the number in their names, e.g. left03.jpg and right03.jpg)")
    pairs = _same_numbering(pairs, cam_a, cam_b, board)
    rms, *_, R, t, _, _ = cv2.stereoCalibrate(
        [p[0] for p in pairs], [p[1].reshape(-1, 1, 2) for p in pairs],
        [p[2].reshape(-1, 1, 2) for p in pairs], cam_a.K, cam_a.dist, cam_b.K, cam_b.dist, size,
        flags=cv2.CALIB_FIX_INTRINSIC)
    return R, t.ravel(), float(rms), len(pairs)


def _same_numbering(pairs, cam_a: Intrinsics, cam_b: Intrinsics, board: Board):
    """Pairs whose second view numbers the corners from the other end are turned back.

    OpenCV numbers a chessboard's corners from the end nearest the image's top left, so two
    cameras may number the same board from opposite ends; the numbering whose relative pose agrees
    with most pairs' is kept.
    """
    if board.charuco:
        return pairs

    def rel(obj, ua, ub):
        _, ra, ta = cv2.solvePnP(obj, ua, cam_a.K, cam_a.dist)
        _, rb, tb = cv2.solvePnP(obj, ub, cam_b.K, cam_b.dist)
        Ra, Rb = cv2.Rodrigues(ra)[0], cv2.Rodrigues(rb)[0]
        return Rb @ Ra.T

    options = [(rel(o, ua, ub), rel(o, ua, ub[::-1])) for o, ua, ub in pairs]
    ref = options[0][0]
    votes = [min(range(2), key=lambda j: np.linalg.norm(opt[j] - ref)) for opt in options]
    keep = int(np.round(np.mean(votes)))  # the majority's numbering of the first pair
    ref = options[0][keep]
    out = []
    for (o, ua, ub), opt in zip(pairs, options):
        j = min(range(2), key=lambda j: np.linalg.norm(opt[j] - ref))
        out.append((o, ua, ub[::-1] if j else ub))
    return out


def mirrored(view: View, board: Board) -> View | None:
    """The same corners numbered with the rows (else the columns) in reverse order, when the
    pattern maps onto itself under that mirror (an even number of inner corners that way)."""
    if board.charuco or len(view.ids) != board.cols * board.rows:
        return None
    grid = view.uv.reshape(board.rows, board.cols, 2)
    if board.rows % 2 == 0:
        return view._replace(uv=grid[::-1].reshape(-1, 2).copy())
    if board.cols % 2 == 0:
        return view._replace(uv=grid[:, ::-1].reshape(-1, 2).copy())
    return None


def _index(name: str) -> str:
    digits = "".join(ch if ch.isdigit() else " " for ch in Path(name).stem).split()
    return digits[-1].lstrip("0") or "0" if digits else name
