"""Vicon calibration (``.xcp``, XML) as Nexus, Tracker and Shogun write it.

Layout read::

    <Cameras>
      <Camera DEVICEID="2114540" USERID="3" DISPLAY_TYPE="Vue" SENSOR_SIZE="1920 1080"
              PIXEL_ASPECT_RATIO="1" SKEW="0" ...>
        <KeyFrames>
          <KeyFrame FRAME="0" FOCAL_LENGTH="1498.2" PRINCIPAL_POINT="958.1 541.7"
                    ORIENTATION="qx qy qz qw" POSITION="x y z"
                    VICON_RADIAL2="Vicon3Parameter cx cy w1 w2 w3" .../>

* image size ``SENSOR_SIZE``; ``FOCAL_LENGTH`` and ``PRINCIPAL_POINT`` in pixels, the vertical
  focal length ``FOCAL_LENGTH / PIXEL_ASPECT_RATIO`` (Pose2Sim's reading; real files say 1);
  ``SKEW`` must be 0;
* pose: ``ORIENTATION`` is the world-to-camera rotation as a quaternion, real part last (Vicon's
  documentation of the format), ``POSITION`` the camera centre in mm; ``T = -R POSITION``;
* lens: Vicon's model maps a *distorted* pixel ``d`` to the ideal one,
  ``c + (d - c)(1 + w1 r^2 + w2 r^4 + w3 r^6)`` with ``r = |d - c|`` in pixels about the centre
  ``c`` of ``VICON_RADIAL2`` (older files: ``VICON_RADIAL="w1 w2"`` about the principal point).
  That is the inverse direction of OpenCV's model, so OpenCV's k1 k2 p1 p2 k3 are fitted to it
  over the whole image by linear least squares; a lens the 5-coefficient model cannot follow
  within :data:`MAX_FIT_PX` is refused.

A moving-camera file (several key frames) is read at its first key frame, with a warning.
Cameras are named after ``DEVICEID`` (Nexus names each camera's video after it).
"""
from __future__ import annotations

import warnings
from pathlib import Path

import cv2
import numpy as np
from scipy.spatial.transform import Rotation

from ...errors import IPFWarning, require
from ...geometry.camera import Camera, validate_camera
from ._xml import image_size, load_root, number, numbers, write_text

WHAT = "Vicon .xcp calibration"
MAX_FIT_PX = 1.0  # pixels: worst difference between Vicon's lens and the fitted OpenCV one
GRID = 31  # sample points per image side for the lens fits


def _grid(w: int, h: int) -> np.ndarray:
    u, v = np.meshgrid(np.linspace(0, w - 1, GRID), np.linspace(0, h - 1, GRID))
    return np.stack([u.ravel(), v.ravel()], 1)  # (G, 2) pixels


def _vicon_to_ideal(d: np.ndarray, c: np.ndarray, w: np.ndarray) -> np.ndarray:
    off = d - c
    r2 = (off ** 2).sum(1, keepdims=True)
    return c + off * (1 + w[0] * r2 + w[1] * r2 ** 2 + w[2] * r2 ** 3)


def _opencv_distort(xi: np.ndarray, k: np.ndarray) -> np.ndarray:
    """OpenCV's forward model on normalised points (G, 2)."""
    k1, k2, p1, p2, k3 = k
    x, y = xi[:, 0], xi[:, 1]
    r2 = x * x + y * y
    rad = 1 + r2 * (k1 + r2 * (k2 + r2 * k3))
    return np.stack([x * rad + 2 * p1 * x * y + p2 * (r2 + 2 * x * x),
                     y * rad + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y], 1)


def fit_opencv(K: np.ndarray, w: int, h: int, centre: np.ndarray, coeffs: np.ndarray):
    """OpenCV (k1, k2, p1, p2, k3) closest to Vicon's lens.

    Returns (dist (5,), worst px difference over the image, worst within the central disc of
    radius half the short side).
    """
    d = _grid(w, h)
    ideal = _vicon_to_ideal(d, centre, coeffs)
    f, pp = np.array([K[0, 0], K[1, 1]]), K[:2, 2]
    xi, xd = (ideal - pp) / f, (d - pp) / f
    x, y = xi[:, 0], xi[:, 1]
    r2 = x * x + y * y
    # xd - xi is linear in the coefficients (k1, k2, k3, p1, p2)
    ax = np.stack([x * r2, x * r2 ** 2, x * r2 ** 3, 2 * x * y, r2 + 2 * x * x], 1)
    ay = np.stack([y * r2, y * r2 ** 2, y * r2 ** 3, r2 + 2 * y * y, 2 * x * y], 1)
    A, b = np.concatenate([ax, ay]), np.concatenate([xd[:, 0] - x, xd[:, 1] - y])
    sol = np.linalg.lstsq(A, b, rcond=None)[0]
    dist = np.array([sol[0], sol[1], sol[3], sol[4], sol[2]])
    err = np.abs((_opencv_distort(xi, dist) - xd) * f).max(1)
    central = np.hypot(*(d - pp).T) <= 0.5 * min(w, h)
    return dist, float(err.max()), float(err[central].max())


def fit_vicon(cam: Camera) -> tuple[np.ndarray, float]:
    """Vicon (w1, w2, w3) about the principal point closest to a camera's OpenCV lens."""
    d = _grid(cam.width, cam.height)
    ideal = cv2.undistortPoints(d.reshape(-1, 1, 2), cam.K, cam.dist, P=cam.K,
                                criteria=(cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100,
                                          1e-12)).reshape(-1, 2)
    # only where OpenCV's polynomial is monotonic (the camera model is linear beyond r_max)
    xi = (ideal - cam.K[:2, 2]) / np.diag(cam.K)[:2]
    keep = np.hypot(xi[:, 0], xi[:, 1]) < cam.r_max()
    d, ideal = d[keep], ideal[keep]
    c = cam.K[:2, 2]
    off = d - c
    r2 = (off ** 2).sum(1)
    A = np.stack([np.concatenate([off[:, i] * r2 ** (j + 1) for i in (0, 1)]) for j in range(3)], 1)
    b = np.concatenate([(ideal - d)[:, i] for i in (0, 1)])
    coeffs = np.linalg.lstsq(A, b, rcond=None)[0]
    err = np.abs(_vicon_to_ideal(d, c, coeffs) - ideal).max()
    return coeffs, float(err)


def read_vicon(path: str | Path) -> list[Camera]:
    """Every camera of a Vicon ``.xcp`` file with a key frame (see module doc), in file order."""
    path = Path(path)
    root = load_root(path, WHAT)
    els = root.findall("Camera") if root.tag == "Cameras" else root.findall(".//Cameras/Camera")
    require(bool(els), f"not a {WHAT} (no <Cameras><Camera ...>)", path)
    cams = []
    for i, el in enumerate(els, start=1):
        name = el.get("DEVICEID") or el.get("USERID") or f"camera{i}"
        where = f"camera {name}"
        frames = el.findall("KeyFrames/KeyFrame")
        if not frames:
            continue  # an uncalibrated device
        if len(frames) > 1:
            warnings.warn(IPFWarning(f"{path}: camera {name} has {len(frames)} key frames (a "
                                     "moving camera): its first is used"), stacklevel=2)
        kf = frames[0]
        w, h = image_size(*numbers(el, "SENSOR_SIZE", where, path, 2), where, path)
        aspect = number(el, "PIXEL_ASPECT_RATIO", where, path, default=1.0)
        require(0.5 < aspect < 2, f"{where}: PIXEL_ASPECT_RATIO {aspect:g} is outside 0.5..2", path)
        skew = number(el, "SKEW", where, path, default=0.0)
        require(skew == 0, f"{where}: non-zero SKEW ({skew:g}) is not supported", path)
        f = number(kf, "FOCAL_LENGTH", where, path)
        require(f > 0, f"{where}: FOCAL_LENGTH must be positive, got {f:g}", path)
        require(f < 1e6, f"{where}: FOCAL_LENGTH {f:g} px is not plausible", path)
        pp = np.array(numbers(kf, "PRINCIPAL_POINT", where, path, 2))
        require(0 <= pp[0] < w and 0 <= pp[1] < h, f"{where}: PRINCIPAL_POINT {pp.tolist()} lies "
                f"outside the {w}x{h} sensor", path)
        q = np.array(numbers(kf, "ORIENTATION", where, path, 4))
        require(abs(np.linalg.norm(q) - 1) < 1e-3, f"{where}: ORIENTATION is not a unit "
                f"quaternion (norm {np.linalg.norm(q):.4g})", path)
        R = Rotation.from_quat(q).as_matrix()
        centre = np.array(numbers(kf, "POSITION", where, path, 3)) * 1e-3
        if kf.get("VICON_RADIAL2") is not None:
            model = (kf.get("VICON_RADIAL2").split() or [""])[0]
            require(model == "Vicon3Parameter", f"{where}: lens model {model[:30]!r} is not "
                    "supported (Vicon3Parameter only)", path)
            vals = numbers(kf, "VICON_RADIAL2", where, path, 5, words=1)
            lens_c, coeffs = np.array(vals[:2]), np.array(vals[2:])
        elif kf.get("VICON_RADIAL") is not None:
            vals = numbers(kf, "VICON_RADIAL", where, path)
            require(1 <= len(vals) <= 3, f"{where}: VICON_RADIAL has {len(vals)} numbers, "
                    "expected 1 to 3", path)
            lens_c, coeffs = pp, np.array(vals + [0.0] * (3 - len(vals)))
        else:
            lens_c, coeffs = pp, np.zeros(3)
        K = np.array([[f, 0.0, pp[0]], [0.0, f / aspect, pp[1]], [0.0, 0.0, 1.0]])
        require(np.all(np.abs(lens_c - pp) < max(w, h)) and np.all(np.abs(coeffs) < 1.0),
                f"{where}: VICON_RADIAL2 centre or coefficients are not plausible "
                f"({lens_c.tolist()}, {coeffs.tolist()})", path)
        with np.errstate(all="ignore"):
            try:
                dist, err, err_centre = fit_opencv(K, w, h, lens_c, coeffs)
            except (np.linalg.LinAlgError, ValueError):
                err = err_centre = float("inf")
        require(np.isfinite(err_centre), f"{where}: its lens (Vicon3Parameter {coeffs.tolist()}) "
                "cannot be converted (the model diverges over the image)", path)
        require(err_centre <= MAX_FIT_PX, f"{where}: its lens (Vicon3Parameter {coeffs.tolist()}) "
                f"cannot be followed by OpenCV's k1 k2 p1 p2 k3 within {MAX_FIT_PX:g} px in the "
                f"image centre (worst {err_centre:.2g} px; are the coefficients per pixel squared, "
                "as Vicon writes them?)", path)
        if err > 0.5:
            warnings.warn(IPFWarning(f"{path}: camera {name}: OpenCV's lens model follows Vicon's "
                                     f"within {err_centre:.2g} px in the image centre but "
                                     f"{err:.2g} px at the edges"), stacklevel=2)
        cam = Camera(K=K, dist=dist, R=R, T=-R @ centre, width=w, height=h, name=name,
                     source=str(path))
        cams.append(validate_camera(cam, str(path)))
    require(bool(cams), f"{WHAT}: no camera has a <KeyFrame>", path)
    return cams


def write_vicon(cameras: list[Camera], path: str | Path) -> Path:
    """Write cameras as an ``.xcp`` file; each lens as the closest Vicon3Parameter model."""
    rows = []
    for c in cameras:
        require(abs(c.K[0, 1]) < 1e-12, f"camera {c.name}: skew cannot be written to an .xcp")
        w, _ = fit_vicon(c)
        q = Rotation.from_matrix(c.R).as_quat()
        x, y, z = c.centre * 1e3
        rows.append(
            f'  <Camera DEVICEID="{c.name}" USERID="{len(rows) + 1}" DISPLAY_TYPE="Vue" '
            f'TYPE="VIDEO" SENSOR_SIZE="{c.width} {c.height}" '
            f'PIXEL_ASPECT_RATIO="{c.K[0, 0] / c.K[1, 1]:.15g}" SKEW="0">\n'
            f'    <KeyFrames>\n      <KeyFrame FRAME="0" FOCAL_LENGTH="{c.K[0, 0]:.12g}" '
            f'PRINCIPAL_POINT="{c.K[0, 2]:.12g} {c.K[1, 2]:.12g}" '
            f'ORIENTATION="{" ".join(f"{v:.15g}" for v in q)}" POSITION="{x:.9g} {y:.9g} {z:.9g}" '
            f'VICON_RADIAL2="Vicon3Parameter {c.K[0, 2]:.12g} {c.K[1, 2]:.12g} '
            f'{w[0]:.15g} {w[1]:.15g} {w[2]:.15g}" WORLD_ERROR="0" IMAGE_ERROR="0"/>\n'
            f'    </KeyFrames>\n  </Camera>')
    text = '<?xml version="1.0" encoding="UTF-8"?>\n<Cameras VERSION="1.0">\n' + "\n".join(rows) \
        + "\n</Cameras>\n"
    write_text(Path(path), text)
    return Path(path)
