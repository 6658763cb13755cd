"""C3D export (Mokka, Vicon Nexus, Visual3D, OpenSim via its C3D adapter), written with ezc3d.

POINT:LABELS are our 19 point names, POINT:RATE the row rate, POINT:UNITS the declared length
unit. Missing points follow the C3D convention: coordinates 0 with residual -1 (ezc3d reads them
back as NaN); present points have residual 0, the value C3D writers use for computed points.
C3D has no up-axis field; POINT:Y_SCREEN names the up axis and POINT:X_SCREEN a horizontal axis,
the viewing hints Mokka and Vicon software honour (and :mod:`ipf_jax.analysis.gait.markers` reads).
Stored frame i is at ``(first_frame + i) / rate`` seconds, with ``first_frame`` chosen so that
this is the run's ``time_s`` (to within half a sample).
"""
from __future__ import annotations

from pathlib import Path

import ezc3d
import numpy as np

from ...body.model import POINT_NAMES
from ...data.rundir import Run, sample_rate
from ...errors import IPFError, require
from ...geometry.world import up_rotation
from .axes import signed_axis_name, to_file_frame, unit_scale


def export_c3d(run: Run, path: str | Path, *, up: str | None = None, units: str = "mm") -> Path:
    """Write the run's 19 points as a C3D file.

    up : file up axis; None keeps the world frame (the run's ``up_axis``). units : m, cm or mm.
    The path must end in ``.c3d`` (ezc3d would append it otherwise).
    """
    path = Path(path)
    require(path.suffix == ".c3d", "a C3D file name must end in .c3d", path)
    unit_scale(units)
    up = run.up_axis if up is None else up
    pts = to_file_frame(run.joints, run.up_axis, up, units)  # (T, J, 3)
    valid = np.isfinite(pts).all(-1)  # (T, J)
    T, J, _ = pts.shape

    rate = sample_rate(run)
    c3d = ezc3d.c3d()
    # Readers time stored frame i at (first_frame + i) / rate: keep the run's clock.
    c3d["header"]["points"]["first_frame"] = int(round(run.time_s[0] * rate))
    point = c3d["parameters"]["POINT"]
    point["RATE"]["value"] = [rate]
    point["LABELS"]["value"] = list(POINT_NAMES)
    point["DESCRIPTIONS"]["value"] = ["ipf-jax key point"] * J
    point["UNITS"]["value"] = [units]
    D = up_rotation(up)
    c3d.add_parameter("POINT", "X_SCREEN", signed_axis_name(D[:, 0]))
    c3d.add_parameter("POINT", "Y_SCREEN", signed_axis_name(D[:, 2]))
    data = np.ones((4, J, T))
    data[:3] = np.where(valid[..., None], pts, 0.0).transpose(2, 1, 0)
    c3d["data"]["points"] = data
    c3d["data"]["meta_points"] = {"residuals": np.where(valid, 0.0, -1.0).T[None]}  # (1, J, T)
    try:
        c3d.write(str(path))
    except (OSError, RuntimeError) as e:
        raise IPFError(f"cannot write C3D ({e})", path) from None
    return path
