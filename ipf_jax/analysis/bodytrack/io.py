"""Readers for PARSEC bodytrack's text files and BMP images (all validated, errors name the file).

Units are bodytrack's own: millimetres and radians. Conversion to metres happens in
:mod:`ipf_jax.analysis.bodytrack.kinematics`, at the point where world coordinates are produced.
"""
from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

import numpy as np

from ...errors import IPFError, require

NUM_POSE = 31
NUM_PARTS = 10
NUM_LENGTHS = 18

#: The 10 truncated-cone parts, in bodytrack's order (BodyGeometry's cylinder index).
PART_NAMES: tuple[str, ...] = (
    "torso", "left_thigh", "left_shin", "right_thigh", "right_shin",
    "left_upper_arm", "left_forearm", "right_upper_arm", "right_forearm", "head",
)


class BodytrackShape(NamedTuple):
    """BodyShapeParameters.txt.

    limbs : (10, 4) per part [bottom radius (mm), top radius (mm), x scale, y scale], in
        :data:`PART_NAMES` order.
    lengths : (18,) mm; see the package docstring for what each index means.
    """

    limbs: np.ndarray
    lengths: np.ndarray


def _numbers(path: Path, what: str) -> list[list[float]]:
    """Non-empty lines of a whitespace-separated number file, as floats (CRLF and tabs tolerated)."""
    try:
        text = path.read_text()
    except FileNotFoundError:
        raise IPFError(f"{what} file not found", path) from None
    except (OSError, UnicodeDecodeError) as e:
        raise IPFError(f"cannot read {what} file ({e})", path) from None
    rows = []
    for lineno, line in enumerate(text.splitlines(), 1):
        row = []
        for token in line.split():
            try:
                row.append(float(token))
            except ValueError:
                raise IPFError(f"line {lineno}: non-numeric text {token[:20]!r}", path) from None
        if row:
            rows.append(row)
    return rows


def read_pose(path: str | Path) -> np.ndarray:
    """Read InitialPose.txt or a poses.txt written by bodytrack.

    Returns
    -------
    poses : (F, 31) float64, one line per frame; angles in radians, pelvis position (3:6) in mm.
        InitialPose.txt gives F = 1.

    Blank lines (bodytrack ends InitialPose.txt with one) and trailing spaces are ignored; every
    other line must hold exactly 31 finite numbers.
    """
    path = Path(path)
    rows = _numbers(path, "pose")
    require(len(rows) > 0, "pose file holds no pose", path)
    for i, row in enumerate(rows):
        require(len(row) == NUM_POSE,
                f"pose {i}: expected {NUM_POSE} numbers per line, found {len(row)}", path)
    poses = np.array(rows, np.float64)
    bad = np.argwhere(~np.isfinite(poses))
    require(len(bad) == 0, f"pose {bad[0][0] if len(bad) else 0}: non-finite number", path)
    return poses


def read_body_shape(path: str | Path) -> BodytrackShape:
    """Read BodyShapeParameters.txt: 58 numbers, 10 x 4 limb values then 18 lengths (mm)."""
    path = Path(path)
    values = [v for row in _numbers(path, "body shape") for v in row]
    n = NUM_PARTS * 4 + NUM_LENGTHS
    require(len(values) == n, f"expected {n} numbers (bodytrack body shape), found {len(values)}",
            path)
    v = np.array(values, np.float64)
    require(bool(np.all(np.isfinite(v))), "body shape contains non-finite numbers", path)
    limbs = v[: NUM_PARTS * 4].reshape(NUM_PARTS, 4)
    lengths = v[NUM_PARTS * 4:]
    require(bool(np.all(limbs > 0)), "limb radii and scales must be positive", path)
    # indices 4, 8, 12, 16 are unused by bodytrack (zero in the data); every other length is used
    used = [i for i in range(NUM_LENGTHS) if i not in (4, 8, 12, 16)]
    require(bool(np.all(lengths[used] > 0)), "segment lengths and offsets must be positive", path)
    return BodytrackShape(limbs, lengths)


def read_bmp(path: str | Path, *, colour: bool = False) -> np.ndarray:
    """Read a bodytrack BMP with row 0 at the top of the image.

    Returns (H, W) uint8 grey values (CAM, FG images), or with ``colour=True`` (H, W, 3) uint8 in
    **RGB** order (Result overlays).
    """
    import cv2  # only the image helpers need OpenCV

    path = Path(path)
    require(path.is_file(), "image file not found", path)
    img = cv2.imread(str(path), cv2.IMREAD_COLOR if colour else cv2.IMREAD_GRAYSCALE)
    require(img is not None, "not a readable image", path)
    return img[..., ::-1].copy() if colour else img


def read_fg_mask(path: str | Path) -> np.ndarray:
    """(H, W) bool foreground mask; bodytrack binarises FG images as ``value != 0``."""
    return read_bmp(path) != 0
