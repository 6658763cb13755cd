"""OptiTrack Motive calibration (``.mcal``, XML, Motive 3.2 and later; usually UTF-16).

Layout read (the fields OptiTrack documents for third-party use)::

    <calibrationProfile>
      <Calibration><Cameras>
        <Camera Serial="C11764">
          <Properties CameraID="13" .../>
          <Attributes ImagerPixelWidth="1920" ImagerPixelHeight="1080" .../>
          <IntrinsicStandardCameraModel HorizontalFocalLength=".." VerticalFocalLength=".."
              LensCenterX=".." LensCenterY=".." k1=".." k2=".." k3=".." TangentialX=".."
              TangentialY=".."/>
          <Extrinsic X=".." Y=".." Z=".." OrientMatrix0=".." ... OrientMatrix8=".."/>

* image size ``ImagerPixelWidth`` x ``ImagerPixelHeight``; intrinsics in pixels from the
  *standard* (OpenCV) model: ``k1 k2 k3`` radial, ``TangentialX``/``TangentialY`` = p1/p2. A
  camera with only ``<Intrinsic>`` (Motive's own lens model) is refused;
* pose: ``X Y Z`` the camera centre in metres; ``OrientMatrix0..8`` the camera's orientation
  ``M`` row by row (camera axes to world; Motive's camera looks along its -z with y up), so
  OpenCV's world-to-camera rotation is ``R = diag(1, -1, -1) M^T`` and ``T = -R c``.

Devices without both elements (eSync, base stations) are skipped; cameras are named by ``Serial``.
The binary ``.cal`` of Motive before 3.2 is not readable (see :mod:`.sniff`).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ...errors import require
from ...geometry.camera import Camera
from ._xml import image_size, load_root, number, pinhole_camera, write_text

WHAT = "OptiTrack .mcal calibration"
FLIP = np.diag([1.0, -1.0, -1.0])


def read_optitrack(path: str | Path) -> list[Camera]:
    """Every camera of a Motive ``.mcal`` file with intrinsics and a pose, in file order."""
    path = Path(path)
    root = load_root(path, WHAT)
    els = root.findall(".//Calibration/Cameras/Camera") or root.findall(".//Cameras/Camera")
    require(bool(els), f"not an {WHAT} (no <Calibration><Cameras><Camera ...>)", path)
    cams = []
    for i, el in enumerate(els, start=1):
        name = el.get("Serial") or f"camera{i}"
        where = f"camera {name}"
        ext, attrs = el.find("Extrinsic"), el.find("Attributes")
        intr = el.find("IntrinsicStandardCameraModel")
        if ext is None and intr is None and el.find("Intrinsic") is None:
            continue  # not a camera (eSync, active base station)
        require(intr is not None, f"{where}: no <IntrinsicStandardCameraModel> (only Motive's own "
                "<Intrinsic> lens model, which is not OpenCV's); export the calibration from "
                "Motive 3.2 or later", path)
        require(ext is not None, f"{where}: missing <Extrinsic> (the camera pose)", path)
        require(attrs is not None, f"{where}: missing <Attributes> (the image size)", path)
        w, h = image_size(number(attrs, "ImagerPixelWidth", where, path),
                          number(attrs, "ImagerPixelHeight", where, path), where, path)
        fx, fy = (number(intr, a, where, path) for a in ("HorizontalFocalLength",
                                                         "VerticalFocalLength"))
        cx, cy = (number(intr, a, where, path) for a in ("LensCenterX", "LensCenterY"))
        k1, k2, k3 = (number(intr, a, where, path, default=0.0) for a in ("k1", "k2", "k3"))
        p1, p2 = (number(intr, a, where, path, default=0.0) for a in ("TangentialX",
                                                                      "TangentialY"))
        centre = np.array([number(ext, a, where, path) for a in "XYZ"])
        M = np.array([number(ext, f"OrientMatrix{j}", where, path) for j in range(9)]).reshape(3, 3)
        R = FLIP @ M.T
        cams.append(pinhole_camera(fx, fy, cx, cy, [k1, k2, p1, p2, k3], R, centre, w, h, name, path))
    require(bool(cams), f"{WHAT}: no camera with intrinsics and a pose", path)
    return cams


def write_optitrack(cameras: list[Camera], path: str | Path, encoding: str = "utf-16") -> Path:
    """Write cameras as a Motive ``.mcal`` file (UTF-16 with BOM, as Motive does)."""
    rows = []
    for k, c in enumerate(cameras, start=1):
        require(abs(c.K[0, 1]) < 1e-12, f"camera {c.name}: skew cannot be written to an .mcal")
        M = (FLIP @ c.R).T
        x, y, z = c.centre
        k1, k2, p1, p2, k3 = c.dist
        orient = " ".join(f'OrientMatrix{j}="{v:.15g}"' for j, v in enumerate(M.ravel()))
        rows.append(
            f'            <Camera Serial="{c.name}">\n'
            f'                <Properties CameraID="{k}" Enabled="1"/>\n'
            f'                <Attributes ImagerPixelWidth="{c.width}" '
            f'ImagerPixelHeight="{c.height}"/>\n'
            f'                <IntrinsicStandardCameraModel HorizontalFocalLength="{c.K[0, 0]:.12g}"'
            f' VerticalFocalLength="{c.K[1, 1]:.12g}" LensCenterX="{c.K[0, 2]:.12g}" '
            f'LensCenterY="{c.K[1, 2]:.12g}" k1="{k1:.12g}" k2="{k2:.12g}" k3="{k3:.12g}" '
            f'TangentialX="{p1:.12g}" TangentialY="{p2:.12g}"/>\n'
            f'                <Extrinsic X="{x:.12g}" Y="{y:.12g}" Z="{z:.12g}" {orient}/>\n'
            f'            </Camera>')
    text = (f'<?xml version="1.0" encoding="{encoding.upper()}"?>\n<calibrationProfile version="1">'
            f'\n    <Calibration>\n        <Cameras Count="{len(rows)}">\n' + "\n".join(rows)
            + "\n        </Cameras>\n    </Calibration>\n</calibrationProfile>\n")
    write_text(Path(path), text, encoding)
    return Path(path)
