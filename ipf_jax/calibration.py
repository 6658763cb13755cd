"""Calibration readers: bodytrack ``.cal``, OpenCV XML/YAML, Pose2Sim/anipose TOML, ipf-jax JSON.

Every reader returns :class:`ipf_jax.camera.Camera` objects in metres and raises
:class:`ipf_jax.errors.IPFError` naming the file and the problem. Image sizes come from the file
when it has them, else from the caller (``width``/``height``, usually the first mask's size).
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from .camera import Camera, validate_camera
from .errors import IPFError, require

_UNITS = {"m": 1.0, "mm": 1e-3, "cm": 1e-2}


def _numbers(path: Path) -> np.ndarray:
    try:
        text = path.read_text()
    except FileNotFoundError:
        raise IPFError("calibration file not found", path) from None
    except (OSError, UnicodeDecodeError) as e:
        raise IPFError(f"cannot read calibration file ({e})", path) from None
    try:
        return np.array([float(t) for t in text.split()], float)
    except ValueError:
        bad = next(t for t in text.split() if not _is_float(t))
        raise IPFError(f"non-numeric text {bad[:20]!r} in calibration file", path) from None


def _is_float(t: str) -> bool:
    try:
        float(t)
        return True
    except ValueError:
        return False


def read_bodytrack_cal(path: str | Path, width: int = 640, height: int = 480) -> Camera:
    """PARSEC bodytrack ``CameraK.cal``: 25 numbers, Bouguet conventions, millimetres.

    fc(2) cc(2) alpha_c kc(5) R(9, row-major) T(3, mm) omc(3). Distortion follows Bouguet's (and
    OpenCV's) model kc = (k1, k2, p1, p2, k3); bodytrack's own code reuses kc[2] for both tangential
    terms, which only matters when kc[2] != kc[3] (zero in every known file).
    """
    path = Path(path)
    v = _numbers(path)
    require(len(v) == 25, f"expected 25 numbers (bodytrack .cal), found {len(v)}", path)
    fc, cc, alpha, kc = v[0:2], v[2:4], v[4], v[5:10]
    K = np.array([[fc[0], alpha * fc[0], cc[0]], [0, fc[1], cc[1]], [0, 0, 1]])
    R = v[10:19].reshape(3, 3)
    T = v[19:22] * 1e-3
    cam = Camera(K=K, dist=kc.copy(), R=R, T=T, width=width, height=height, name=path.stem,
                 source=str(path))
    return validate_camera(cam, str(path))


def read_json(path: str | Path, width: int | None = None, height: int | None = None) -> list[Camera]:
    """ipf-jax camera JSON (see docs/formats.md)."""
    path = Path(path)
    try:
        doc = json.loads(path.read_text())
    except FileNotFoundError:
        raise IPFError("calibration file not found", path) from None
    except (OSError, ValueError) as e:
        raise IPFError(f"not a readable JSON calibration ({e})", path) from None
    require(isinstance(doc, dict) and isinstance(doc.get("cameras"), list) and doc["cameras"],
            "JSON calibration needs a non-empty 'cameras' list", path)
    unit = doc.get("units", "m")
    require(unit in _UNITS, f"unknown units {unit!r} (m, cm, mm)", path)
    cams = []
    for i, c in enumerate(doc["cameras"]):
        try:
            K = np.array(c["K"], float)
            dist = np.zeros(5)
            d = np.array(c.get("dist", []), float).ravel()
            require(len(d) <= 5, f"camera {i}: at most 5 distortion coefficients", path)
            dist[: len(d)] = d
            if "R" in c:
                R = np.array(c["R"], float)
            else:
                R = rodrigues(np.array(c["rvec"], float))
            T = np.array(c["T"], float) * _UNITS[unit]
            w = int(c.get("width", width or 0))
            h = int(c.get("height", height or 0))
        except (KeyError, TypeError, ValueError) as e:
            raise IPFError(f"camera {i}: missing or malformed field ({e})", path) from None
        require(w > 0 and h > 0, f"camera {i}: image size unknown (give width/height)", path)
        cam = Camera(K=K, dist=dist, R=R, T=T, width=w, height=h,
                     name=str(c.get("name", f"camera{i + 1}")), source=str(path))
        cams.append(validate_camera(cam, str(path)))
    return cams


def write_json(cameras: list[Camera], path: str | Path) -> None:
    """Write cameras in the ipf-jax JSON format (metres)."""
    doc = {"format": "ipf-jax-cameras", "version": 1, "units": "m", "cameras": [
        {"name": c.name, "width": c.width, "height": c.height, "K": c.K.tolist(),
         "dist": c.dist.tolist(), "R": c.R.tolist(), "T": c.T.tolist()} for c in cameras]}
    Path(path).write_text(json.dumps(doc, indent=1))


def rodrigues(rvec: np.ndarray) -> np.ndarray:
    """Rotation matrix of a Rodrigues vector (3,)."""
    rvec = np.asarray(rvec, float).ravel()
    require(rvec.shape == (3,) and np.all(np.isfinite(rvec)), "rotation vector must be 3 finite numbers")
    theta = np.linalg.norm(rvec)
    if theta < 1e-12:
        return np.eye(3)
    k = rvec / theta
    Kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(theta) * Kx + (1 - np.cos(theta)) * Kx @ Kx
