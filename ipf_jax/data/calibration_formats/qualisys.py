"""Qualisys QTM calibration exported as text (``Calib.qca.txt``, XML).

Layout read (QTM's export and its real-time protocol share it)::

    <calibration ...>  (possibly inside <QTM_Parameters_Ver_1.xx>)
      <cameras>
        <camera active="1" serial="28526" model="Miqus Video" viewrotation="0" ...>
          <fov_video left="0" top="0" right="1087" bottom="1919"/>     (inclusive pixel bounds)
          <transform x=".." y=".." z=".." r11=".." ... r33=".."/>      (camera pose, mm)
          <intrinsic focalLengthU=".." focalLengthV=".." centerPointU=".." centerPointV=".."
                     skew="0" radialDistortion1..3=".." tangentalDistortion1..2=".."/>

* image size: ``fov_video`` right - left + 1 by bottom - top + 1 pixels;
* intrinsics: focal lengths and centre are in 1/64 pixel of the sensor; the centre is moved by the
  video window's ``left``/``top``; radial/tangential coefficients are OpenCV's k1 k2 k3 p1 p2 in
  normalised coordinates, used as they are (Pose2Sim divides them by 64 as well; the values real
  files hold, k1 ~ -0.05..-0.15, are normalised-coordinate values);
* pose: ``x y z`` is the camera centre in mm; with ``M`` the matrix ``r11..r33`` (row i, column j),
  world-to-camera is ``X_q = M (X - c)`` in QTM's camera frame (x right, y up, looking along -z),
  so OpenCV's rotation is ``R = diag(1, -1, -1) M`` and ``T = -R c``. Two independent published
  readers (Pose2Sim's ``calib_qca`` conversion and a projection tool checked on real overlays) use
  this convention.

Cameras whose ``calibrated`` attribute is ``false`` are skipped; each camera is named after its
``serial`` (QTM names exported videos after it, ``..._Miqus_3_28526.avi``).
"""
from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from ...errors import IPFWarning, require
from ...geometry.camera import Camera
from ._xml import image_size, load_root, number, pinhole_camera, write_text

WHAT = "Qualisys .qca.txt calibration"
SUBPIXEL = 64.0  # QTM's sensor coordinates are in 1/64 pixel
FLIP = np.diag([1.0, -1.0, -1.0])  # QTM camera frame (y up, looking along -z) -> OpenCV's


def _cameras_element(root, path: Path):
    cal = root if root.tag == "calibration" else root.find(".//calibration")
    require(cal is not None, f"not a {WHAT} (no <calibration> element)", path)
    cams = cal.find("cameras")
    require(cams is not None and len(cams.findall("camera")) > 0,
            f"{WHAT} without cameras (<cameras><camera ...>)", path)
    return cams.findall("camera")


def read_qualisys(path: str | Path) -> list[Camera]:
    """Every calibrated camera of a Qualisys ``.qca.txt`` file (see module doc), in file order."""
    path = Path(path)
    root = load_root(path, WHAT)
    cams = []
    for i, el in enumerate(_cameras_element(root, path), start=1):
        name = el.get("serial") or f"camera{i}"
        where = f"camera {name}"
        if (el.get("calibrated") or "true").lower() == "false":
            continue
        fov, tr, intr = el.find("fov_video"), el.find("transform"), el.find("intrinsic")
        require(fov is not None, f"{where}: missing <fov_video> (the image size)", path)
        require(tr is not None, f"{where}: missing <transform> (the camera pose)", path)
        require(intr is not None, f"{where}: missing <intrinsic>", path)
        left, top = number(fov, "left", where, path), number(fov, "top", where, path)
        w, h = image_size(number(fov, "right", where, path) - left + 1,
                          number(fov, "bottom", where, path) - top + 1, f"{where} fov_video", path)
        skew = number(intr, "skew", where, path, default=0.0)
        require(skew == 0, f"{where}: non-zero skew ({skew:g}) is not supported", path)
        fx, fy = (number(intr, a, where, path) / SUBPIXEL for a in ("focalLengthU", "focalLengthV"))
        cx = number(intr, "centerPointU", where, path) / SUBPIXEL - left
        cy = number(intr, "centerPointV", where, path) / SUBPIXEL - top
        k1, k2, k3 = (number(intr, f"radialDistortion{j}", where, path, default=0.0)
                      for j in (1, 2, 3))
        p1, p2 = (number(intr, f"tangentalDistortion{j}", where, path, default=0.0)
                  for j in (1, 2))
        centre = np.array([number(tr, a, where, path) for a in "xyz"]) * 1e-3
        M = np.array([[number(tr, f"r{r}{c}", where, path) for c in (1, 2, 3)] for r in (1, 2, 3)])
        R = FLIP @ M
        view = number(el, "viewrotation", where, path, default=0.0)
        if view != 0:
            warnings.warn(IPFWarning(f"{path}: camera {name}: viewrotation {view:g} (QTM's display "
                                     f"rotation) is ignored: frames are taken as the sensor's "
                                     f"{w}x{h} window"), stacklevel=2)
        cams.append(pinhole_camera(fx, fy, cx, cy, [k1, k2, p1, p2, k3], R, centre, w, h, name, path))
    require(bool(cams), f"{WHAT}: no calibrated camera", path)
    return cams


def write_qualisys(cameras: list[Camera], path: str | Path) -> Path:
    """Write cameras as a ``.qca.txt`` file (the layout :func:`read_qualisys` reads)."""
    rows = []
    for c in cameras:
        require(abs(c.K[0, 1]) < 1e-12, f"camera {c.name}: skew cannot be written to a .qca.txt")
        M = FLIP @ c.R
        x, y, z = c.centre * 1e3
        k1, k2, p1, p2, k3 = c.dist
        fov = f'left="0" top="0" right="{c.width - 1}" bottom="{c.height - 1}"'
        rot = " ".join(f'r{r + 1}{k + 1}="{M[r, k]:.12g}"' for r in range(3) for k in range(3))
        rows.append(
            f'    <camera active="1" calibrated="true" serial="{c.name}" model="Miqus Video" '
            f'viewrotation="0" avg-residual="0.0">\n'
            f'      <fov_marker {fov}/>\n      <fov_marker_max {fov}/>\n'
            f'      <fov_video {fov}/>\n      <fov_video_max {fov}/>\n'
            f'      <transform x="{x:.9g}" y="{y:.9g}" z="{z:.9g}" {rot}/>\n'
            f'      <intrinsic focallength="0" sensorMinU="0" sensorMaxU="{c.width * 64 - 1}" '
            f'sensorMinV="0" sensorMaxV="{c.height * 64 - 1}" '
            f'focalLengthU="{c.K[0, 0] * SUBPIXEL:.12g}" focalLengthV="{c.K[1, 1] * SUBPIXEL:.12g}" '
            f'centerPointU="{c.K[0, 2] * SUBPIXEL:.12g}" centerPointV="{c.K[1, 2] * SUBPIXEL:.12g}" '
            f'skew="0" radialDistortion1="{k1:.12g}" radialDistortion2="{k2:.12g}" '
            f'radialDistortion3="{k3:.12g}" tangentalDistortion1="{p1:.12g}" '
            f'tangentalDistortion2="{p2:.12g}"/>\n    </camera>')
    text = ('<?xml version="1.0" encoding="UTF-8"?>\n<calibration source="ipf-jax" '
            'type="regular">\n  <cameras>\n' + "\n".join(rows) + "\n  </cameras>\n</calibration>\n")
    write_text(Path(path), text)
    return Path(path)
