"""File axes and length units of exported files.

Exported files may use another up axis and another length unit than the run (world frame,
metres). The change of axes is one proper rotation, the same for every format:

    P = up_rotation(out_up) @ up_rotation(run_up).T

It takes the run's up axis onto ``out_up`` and the run's reference heading (the body's forward
axis at ``root_yaw = 0``) onto the reference heading of ``out_up``; with ``out_up == run_up`` it is
the identity, so the world frame is kept as it is. See ``docs/export.md`` for the resulting axis
table.
"""
from __future__ import annotations

import numpy as np

from ...errors import IPFError
from ...geometry.world import AXES, up_rotation

#: Length units an export can declare, and their size in metres^-1.
UNIT_SCALE: dict[str, float] = {"m": 1.0, "cm": 100.0, "mm": 1000.0}


def unit_scale(units: str) -> float:
    """Numbers per metre in ``units`` (``m``, ``cm`` or ``mm``)."""
    if units not in UNIT_SCALE:
        raise IPFError(f"unknown length unit {units!r} (choose one of {', '.join(UNIT_SCALE)})")
    return UNIT_SCALE[units]


def decimals(units: str) -> int:
    """Decimals that keep the run's micrometre resolution (6 decimals of metres) in ``units``."""
    return 6 - int(round(np.log10(unit_scale(units))))


def file_rotation(run_up: str, out_up: str) -> np.ndarray:
    """(3, 3) proper rotation P from world coordinates to file coordinates (see module doc)."""
    if out_up not in AXES:
        raise IPFError(f"unknown up axis {out_up!r} (choose one of {', '.join(AXES)})")
    return up_rotation(out_up) @ up_rotation(run_up).T


def to_file_frame(points: np.ndarray, run_up: str, out_up: str, units: str) -> np.ndarray:
    """Rotate and scale world points into file axes and units.

    points : (..., 3) metres, world frame; NaN stays NaN.
    Returns (..., 3) in ``units``, file axes.
    """
    P = file_rotation(run_up, out_up)
    return (np.asarray(points, float) @ P.T) * unit_scale(units)


def signed_axis_name(v: np.ndarray) -> str:
    """The name (``+X`` ... ``-Z``) of a signed coordinate axis given as a (3,) unit vector."""
    i = int(np.argmax(np.abs(v)))
    return ("+" if v[i] > 0 else "-") + "XYZ"[i]
