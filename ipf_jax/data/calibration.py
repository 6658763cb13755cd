"""Calibration readers: bodytrack ``.cal``, OpenCV XML/YAML, Pose2Sim/anipose TOML, ipf-jax JSON.

Every reader returns :class:`ipf_jax.geometry.camera.Camera` objects in metres and raises
:class:`ipf_jax.errors.IPFError` naming the file and the problem. Image sizes come from the file
when it has them, else from the caller (``width``/``height``, usually the first frame's size).
:func:`read_calibration` picks the reader from a file's extension (or content) or a folder's layout.
"""
from __future__ import annotations

import json
import re
import warnings
from pathlib import Path

import cv2
import numpy as np

from ..errors import IPFError, IPFWarning, require
from ..geometry.camera import Camera, validate_camera
from .calibration_formats import read_optitrack, read_qualisys, read_vicon
from .calibration_formats.sniff import kind_of

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

_UNITS = {"m": 1.0, "mm": 1e-3, "cm": 1e-2}


def _text(path: Path) -> str:
    try:
        return path.read_text()
    except FileNotFoundError:
        raise IPFError("calibration file not found", path) from None
    except (OSError, UnicodeDecodeError) as e:
        raise IPFError(f"cannot read calibration file ({e})", path) from None


def _numbers(path: Path) -> np.ndarray:
    text = _text(path)
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


def _natural_key(p: Path) -> list:
    # Camera10 after Camera9, not after Camera1
    return [int(t) if t.isdigit() else t.lower() for t in re.split(r"(\d+)", p.as_posix())]


def _unit_scale(units: str, path: Path) -> float:
    require(units in _UNITS, f"unknown units {units!r} (m, cm, mm)", path)
    return _UNITS[units]


def _array(value, what: str, path: Path) -> np.ndarray:
    """A nested list of numbers -> float array, with the problem named when it is not one."""
    try:
        return np.array(value, float)
    except TypeError:
        raise IPFError(f"non-numeric value in {what}", path) from None
    except ValueError as e:  # a string that is no number, or rows of different lengths
        problem = "ragged (rows of different lengths)" if "inhomogeneous" in str(e) else \
            "non-numeric"
        raise IPFError(f"{what} is {problem}", path) from None


def _intrinsics(K, path: Path) -> np.ndarray:
    K = np.asarray(K, float)
    require(K.shape == (3, 3), f"camera matrix has shape {K.shape}, expected 3x3", path)
    return K  # its entries: validate_camera (every reader's cameras)


def _distortion(d, path: Path) -> np.ndarray:
    """(5,) k1 k2 p1 p2 k3 from 4, 5 or more OpenCV coefficients (extra ones must be zero)."""
    d = np.asarray(d, float).ravel()
    require(len(d) >= 4, f"{len(d)} distortion coefficients, expected 4 (k1 k2 p1 p2), 5 or more",
            path)
    # 8/12/14 coefficients add rational, thin-prism and tilt terms the camera model lacks:
    # dropping non-zero ones would move every projected point
    extra = d[5:]
    require(not np.any(extra), f"distortion terms beyond k1 k2 p1 p2 k3 are non-zero "
            f"({', '.join(f'{x:.3g}' for x in extra)}); only the 5-coefficient model is supported",
            path)
    out = np.zeros(5)
    out[: min(len(d), 5)] = d[:5]
    return out


def _rotation(r, path: Path) -> np.ndarray:
    """Rodrigues vector (3 numbers) or 3x3 matrix -> (3, 3); orthonormality is checked later."""
    r = np.asarray(r, float)
    require(bool(np.all(np.isfinite(r))), "rotation contains non-finite numbers", path)
    if r.size == 3:
        return rodrigues(r)
    require(r.shape == (3, 3),
            f"rotation has shape {r.shape}, expected 3 numbers (Rodrigues) or a 3x3 matrix", path)
    return r


def _translation(t, scale: float, path: Path) -> np.ndarray:
    t = np.asarray(t, float)
    require(t.size == 3, f"translation has {t.size} numbers, expected 3", path)
    return t.ravel() * scale


def _image_size(in_file, width, height, path: Path) -> tuple[int, int]:
    """Image size: the file's when it has one (it must match the caller's), else the caller's."""
    if in_file is not None:
        require(all(np.isfinite(x) and 0 < x <= 100_000 for x in in_file),
                f"image size {' x '.join(f'{x:g}' for x in in_file)} is not a positive number of "
                "pixels (at most 100000)", path)
        w, h = (int(round(x)) for x in in_file)
        require(width is None or height is None or (width, height) == (w, h),
                f"calibration is for {w}x{h} images but the frames are {width}x{height}", path)
        return w, h
    require(width is not None and height is not None,
            "image size is not in the calibration file: give width and height (first frame's size)",
            path)
    return int(width), int(height)


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


def read_bodytrack_dir(root: str | Path, width: int = 640, height: int = 480) -> list[Camera]:
    """A bodytrack ``CALIB`` folder: ``Camera1.cal`` .. ``CameraN.cal`` in numeric order."""
    root = Path(root)
    files = sorted(root.glob("Camera*.cal"), key=_natural_key)
    require(bool(files), "no Camera*.cal files in calibration folder", root)
    return [read_bodytrack_cal(f, width, height) for f in files]


# --- OpenCV FileStorage (XML / YAML) -------------------------------------------------------------

_CV_KEYS = {  # accepted node names, ours (uu config.xml) first, then OpenCV's calibration sample
    "K": ("CameraMatrix", "camera_matrix", "K"),
    "dist": ("DistortionCoeffs", "distortion_coefficients", "dist_coeffs", "D"),
    "R": ("Rotation", "rvec", "R"),
    "T": ("Translation", "tvec", "T"),
}


def _cv_numbers(node, key: str, path: Path) -> np.ndarray:
    """A FileStorage matrix, sequence or scalar node -> float array (matrix shape kept)."""
    shape = None
    if node.isMap():  # !!opencv-matrix: rows, cols, dt, data
        rows, cols, data = node.getNode("rows"), node.getNode("cols"), node.getNode("data")
        require(rows.isInt() and cols.isInt() and data.isSeq(),
                f"{key} is not an OpenCV matrix (needs rows, cols, data)", path)
        channels = int(re.match(r"\d*", node.getNode("dt").string() or "").group() or 1)
        shape = (int(rows.real()), int(cols.real())) + ((channels,) if channels > 1 else ())
        items = [data.at(i) for i in range(data.size())]
    elif node.isSeq():
        items = [node.at(i) for i in range(node.size())]
    else:
        items = [node]
    values = []
    for it in items:
        require(it.isInt() or it.isReal(),
                f"non-numeric text {str(it.string())[:20]!r} in {key}", path)
        values.append(it.real())
    if shape is not None:
        require(len(values) == int(np.prod(shape)),
                f"{key} has {len(values)} numbers, expected {int(np.prod(shape))} "
                f"({shape[0]}x{shape[1]})", path)
        return np.array(values, float).reshape(shape)
    return np.array(values, float)


def read_opencv(path: str | Path, width: int | None = None, height: int | None = None, *,
                units: str = "mm", name: str | None = None) -> list[Camera]:
    """One camera from an OpenCV FileStorage file (``config.xml``, ``.yml``, ``.yaml``).

    Nodes: ``CameraMatrix`` (3x3), ``DistortionCoeffs`` (4, 5 or more: k1 k2 p1 p2 [k3 ...]; terms
    past k3 must be zero), ``Rotation`` (3x1 Rodrigues or 3x3, world to camera) and ``Translation``
    (3x1, in ``units``: millimetres by default, as OpenCV calibrations measured on a board in mm
    are). OpenCV-sample names (``camera_matrix``, ``distortion_coefficients``, ``rvec``, ``tvec``)
    are accepted too. The image size is not in these files unless ``image_width``/``image_height``
    are: pass the first frame's ``width`` and ``height``. The camera is named after its folder
    when the file is ``config.*`` (``cam3/config.xml`` -> ``cam3``), else after the file.

    Returns a list holding the one camera, like every multi-camera reader.
    """
    path = Path(path)
    require(path.is_file(), "calibration file not found", path)
    scale = _unit_scale(units, path)
    try:
        fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    except (cv2.error, SystemError) as e:  # cv2 5 wraps parse errors in SystemError
        cause = str(e.__cause__ or e)
        line = re.search(r"line (\d+)", cause) or re.search(r"\((\d+)\)", cause)
        where = f" (parse error near line {line.group(1)})" if line else ""
        raise IPFError(f"not a readable OpenCV XML/YAML file{where}", path) from None
    try:
        require(fs.isOpened() and fs.root().isMap(), "not a readable OpenCV XML/YAML file", path)
        found = {}
        for field, names in _CV_KEYS.items():
            node = next((nd for nd in map(fs.getNode, names) if not nd.empty()), None)
            require(node is not None, f"missing {names[0]} (or {', '.join(names[1:])})", path)
            found[field] = _cv_numbers(node, names[0], path)
        wn, hn = fs.getNode("image_width"), fs.getNode("image_height")
        size = (wn.real(), hn.real()) if wn.isInt() and hn.isInt() else None
    except cv2.error as e:  # a node of an unexpected kind
        raise IPFError(f"unexpected OpenCV XML/YAML layout ({str(e).strip()[-80:]})",
                       path) from None
    finally:
        fs.release()
    w, h = _image_size(size, width, height, path)
    if name is None:
        name = path.parent.name if path.stem.lower() == "config" else path.stem
    cam = Camera(K=_intrinsics(found["K"], path), dist=_distortion(found["dist"], path),
                 R=_rotation(found["R"], path), T=_translation(found["T"], scale, path),
                 width=w, height=h, name=name, source=str(path))
    return [validate_camera(cam, str(path))]


def read_opencv_dir(root: str | Path, width: int | None = None, height: int | None = None, *,
                    units: str = "mm") -> list[Camera]:
    """Every ``cam*/config.xml`` (or ``.yml``/``.yaml``) under ``root``, in natural order."""
    root = Path(root)
    files = sorted((f for ext in ("xml", "yml", "yaml") for f in root.glob(f"cam*/config.{ext}")),
                   key=_natural_key)
    require(bool(files), "no cam*/config.xml files in calibration folder", root)
    return [read_opencv(f, width, height, units=units)[0] for f in files]


# --- Pose2Sim / anipose TOML ---------------------------------------------------------------------

def read_toml(path: str | Path, width: int | None = None, height: int | None = None, *,
              units: str = "m") -> list[Camera]:
    """Pose2Sim / anipose TOML: one table per camera, ``[metadata]`` skipped.

    Per camera: ``name``, ``size`` [w, h], ``matrix`` (3x3), ``distortions`` (k1 k2 p1 p2 [k3]),
    ``rotation`` (Rodrigues, world to camera), ``translation`` (metres), ``fisheye`` (must be
    false: the fisheye model is not supported). Cameras keep the file's order.
    """
    path = Path(path)
    scale = _unit_scale(units, path)
    try:
        doc = tomllib.loads(_text(path))
    except tomllib.TOMLDecodeError as e:
        raise IPFError(f"not a readable TOML calibration ({e})", path) from None
    tables = {k: v for k, v in doc.items() if isinstance(v, dict) and k != "metadata"}
    require(bool(tables), "no camera tables in TOML calibration", path)
    cams = []
    for key, t in tables.items():
        where = f"camera [{key}]"
        require(not t.get("fisheye", False),
                f"{where}: fisheye cameras are not supported (fisheye = true)", path)
        missing = [f for f in ("matrix", "distortions", "rotation", "translation") if f not in t]
        require(not missing, f"{where}: missing {', '.join(missing)}", path)
        K, dist, rvec, tvec = (_array(t[f], f"{where} {f}", path)
                               for f in ("matrix", "distortions", "rotation", "translation"))
        size = _array(t["size"], f"{where} size", path).ravel() if "size" in t else None
        require(size is None or size.shape == (2,), f"{where}: size must be [width, height]", path)
        w, h = _image_size(size, width, height, path)
        cam = Camera(K=_intrinsics(K, path), dist=_distortion(dist, path),
                     R=_rotation(rvec, path), T=_translation(tvec, scale, path),
                     width=w, height=h, name=str(t.get("name", key)), source=str(path))
        cams.append(validate_camera(cam, str(path)))
    return cams


# --- ipf-jax JSON --------------------------------------------------------------------------------

_JSON_CAMERA_KEYS = {"name", "width", "height", "K", "dist", "R", "rvec", "T"}
_JSON_CAMERA_NOTES = {"reprojection_error_px", "extrinsics_from"}  # what ipf-jax calibrate adds


def read_json(path: str | Path, width: int | None = None, height: int | None = None) -> list[Camera]:
    """ipf-jax camera JSON (see docs/formats.md)."""
    path = Path(path)
    try:
        doc = json.loads(_text(path))
    except ValueError as e:
        raise IPFError(f"not a readable JSON calibration ({e})", path) from None
    require(isinstance(doc, dict) and isinstance(doc.get("cameras"), list) and doc["cameras"],
            "JSON calibration needs a non-empty 'cameras' list", path)
    unit = doc.get("units", "m")
    require(unit in _UNITS, f"unknown units {unit!r} (m, cm, mm)", path)
    cams = []
    for i, c in enumerate(doc["cameras"]):
        require(isinstance(c, dict), f"camera {i}: must be an object", path)
        unknown = sorted(set(c) - _JSON_CAMERA_KEYS - _JSON_CAMERA_NOTES)
        if unknown:  # a misspelt "dist" would leave the lens undistorted without a word
            warnings.warn(IPFWarning(f"{path}: camera {i}: unknown key(s) {', '.join(unknown)} "
                                     f"ignored (read: {', '.join(sorted(_JSON_CAMERA_KEYS))})"),
                          stacklevel=2)
        require(not ("R" in c and "rvec" in c), f"camera {i}: give R or rvec, not both", path)
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


def distinct_names(cams: list[Camera], path) -> list[Camera]:
    """``cams``, or one error when two share a name (before picking cameras by name; a calibration
    whose cameras are taken in order may repeat a name)."""
    names = [c.name for c in cams]
    twice = sorted({n for n in names if names.count(n) > 1})
    require(not twice, f"two cameras share the name {', '.join(twice)}: give each its own", path)
    return cams


def write_json(cameras: list[Camera], path: str | Path) -> None:
    """Write cameras in the ipf-jax JSON format (metres)."""
    doc = {"format": "ipf-jax-cameras", "version": 1, "units": "m", "cameras": [
        {"name": c.name, "width": int(c.width), "height": int(c.height), "K": c.K.tolist(),
         "dist": c.dist.tolist(), "R": c.R.tolist(), "T": c.T.tolist()} for c in cameras]}
    Path(path).write_text(json.dumps(doc, indent=1))


# --- any of the above ----------------------------------------------------------------------------

_LAB_READERS = {"qualisys": read_qualisys, "vicon": read_vicon, "optitrack": read_optitrack}


def read_calibration(path: str | Path, width: int | None = None, height: int | None = None, *,
                     units: str | None = None) -> list[Camera]:
    """Read any supported calibration: a file, a bodytrack ``CALIB`` folder or ``cam*/config.xml``.

    path : a bodytrack ``.cal`` (mm), OpenCV ``.xml``/``.yml`` (``units`` default mm),
        Pose2Sim/anipose ``.toml`` (m), ipf-jax ``.json``, Qualisys ``.qca.txt``, Vicon ``.xcp``
        or OptiTrack ``.mcal`` file, recognised from its content
        (:func:`ipf_jax.calibration_formats.kind_of`; another kind of file is named in the error).
        A folder holding ``Camera*.cal`` (or a ``CALIB`` subfolder with them) or
        ``cam*/config.xml``.
    width, height : image size when the file has none (bodytrack defaults to 640x480).
    units : translation units for OpenCV (default ``"mm"``) or TOML (default ``"m"``) files;
        refused for the others (``.cal`` is in mm, JSON says its units).

    Returns the cameras, C of them, in the order of the file or in natural order of file names.
    """
    path = Path(path)
    if path.is_dir():
        calib = path / "CALIB" if any((path / "CALIB").glob("Camera*.cal")) else path
        if any(calib.glob("Camera*.cal")):
            require(units is None, "units apply to OpenCV and TOML files only (.cal is in mm)",
                    path)
            return read_bodytrack_dir(calib, width or 640, height or 480)
        if any(path.glob("cam*/config.*")):
            return read_opencv_dir(path, width, height, units=units or "mm")
        raise IPFError("no calibration in folder (looked for Camera*.cal, CALIB/Camera*.cal, "
                       "cam*/config.xml)", path)
    require(path.exists(), "calibration file not found", path)
    kind = kind_of(path)  # from the content: an .xml may be OpenCV's, Qualisys', Vicon's ...
    require(units is None or kind in ("opencv", "toml"),
            f"units apply to OpenCV and TOML files only (a {kind} file fixes its own)", path)
    if kind in _LAB_READERS:
        return _LAB_READERS[kind](path)
    if kind == "cal":
        return [read_bodytrack_cal(path, width or 640, height or 480)]
    if kind == "opencv":
        return read_opencv(path, width, height, units=units or "mm")
    if kind == "toml":
        return read_toml(path, width, height, units=units or "m")
    return read_json(path, width, height)


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
