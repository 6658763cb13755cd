"""A tracking run directory (``ipf-jax track --out DIR``): read it, or synthesise one for tests.

Layout (see ``docs/formats.md``): ``joints.csv`` (T frames x 19 points x 3, metres, world frame),
``poses.csv`` (T x 31 DOF, radians / metres), ``run.json`` (``fps``, ``up_axis``, ``shape``, ...).
Missing frames are rows of ``nan`` in both CSV files.
"""
from __future__ import annotations

import json
from pathlib import Path
from typing import NamedTuple

import numpy as np

from ..body.model import NUM_DOF, NUM_POINTS, SHAPE_PARAM_NAMES
from ..body.shape import BodyShape, default_shape, with_legacy_params
from ..errors import IPFError, load_json, require
from ..geometry.host import forward_kinematics
from ..geometry.world import AXES, axis_vector, up_rotation
from .runfiles import JOINT_COLUMNS, POSE_COLUMNS, read_table, write_rows


class Run(NamedTuple):
    """A run directory in memory (T frames).

    frames : (T,) int64 dataset frame numbers.  time_s : (T,) float64 seconds.
    joints : (T, J, 3) float64 metres, world frame; NaN where a frame is missing.
    poses : (T, D) float64 radians / metres, NaN rows where missing; None without ``poses.csv``.
    fps : dataset frame rate.  up_axis : the world's up axis (``+x`` ... ``-z``).
    shape : the body shape used (None when ``run.json`` has no ``shape``).  meta : all of run.json.
    """

    path: Path
    frames: np.ndarray
    time_s: np.ndarray
    joints: np.ndarray
    poses: np.ndarray | None
    fps: float
    up_axis: str
    shape: BodyShape | None
    meta: dict


# --------------------------------------------------------------------------------------------------
# Reading


def _read_table(path: Path, header: list[str]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A CSV with exactly ``header`` (``frame,time_s,...``) -> frames (T,), time_s (T,), values."""
    found, data = read_table(path, path.name)
    if found != header:
        wrong = next((f"column {i + 1} is {h!r}, expected {e!r}"
                      for i, (h, e) in enumerate(zip(found, header)) if h != e),
                     f"{len(found)} columns, expected {len(header)}")
        raise IPFError(f"unexpected header: {wrong}", path)
    frames = data[:, 0]
    require(bool(np.all(np.isfinite(frames))) and bool(np.all(frames == np.round(frames))),
            "the frame column must hold integers on every row", path)
    require(bool(np.all(np.diff(frames) > 0)), "frame numbers must increase", path)
    return frames.astype(np.int64), data[:, 1], data[:, 2:]


def _shape_from_json(doc: object, path: Path) -> BodyShape:
    # run.json embeds a shape file's content; its values were validated when tracking started.
    try:
        params = with_legacy_params(doc["params"], path, warn=False)  # type: ignore[index]
        values = np.array([float(params[n]) for n in SHAPE_PARAM_NAMES])
        height = float(doc.get("height_m", 1.75))  # type: ignore[union-attr]
    except (TypeError, KeyError, ValueError, AttributeError) as e:
        raise IPFError(f"'shape' is not a shape object with every parameter ({e!r})", path) from None
    require(bool(np.all(np.isfinite(values))), "'shape' parameters must be finite", path)
    return BodyShape(values, height)


def _read_meta(path: Path) -> tuple[dict, float, str, BodyShape | None]:
    meta = load_json(path, "run.json")
    require(isinstance(meta, dict), "must hold a JSON object", path)
    fps = meta.get("fps")
    require(isinstance(fps, (int, float)) and not isinstance(fps, bool) and np.isfinite(fps)
            and fps > 0, f"'fps' must be a positive number, got {fps!r}", path)
    up = meta.get("up_axis")
    require(up in AXES, f"'up_axis' must be one of {', '.join(AXES)}, got {up!r}", path)
    shape = _shape_from_json(meta["shape"], path) if "shape" in meta else None
    return meta, float(fps), str(up), shape


def read_run(run_dir: str | Path) -> Run:
    """Read a run directory; ``poses.csv`` is optional (only BVH export needs it).

    Raises :class:`IPFError` naming the file and the problem.
    """
    run_dir = Path(run_dir)
    require(not run_dir.is_file(), "is a file: give the run's folder (the one holding run.json and "
            "joints.csv)", run_dir)
    require(run_dir.is_dir(), "run directory not found", run_dir)
    meta, fps, up, shape = _read_meta(run_dir / "run.json")
    jpath = run_dir / "joints.csv"
    frames, time_s, values = _read_table(jpath, JOINT_COLUMNS)
    joints = values.reshape(-1, NUM_POINTS, 3)  # (T, J, 3)
    poses = None
    ppath = run_dir / "poses.csv"
    if ppath.exists():
        pframes, _, poses = _read_table(ppath, POSE_COLUMNS)
        require(np.array_equal(pframes, frames), "frame numbers differ from joints.csv", ppath)
    # Missing rows may carry nan times; the frame number still fixes them.
    time_s = np.where(np.isfinite(time_s), time_s, frames / fps)
    return Run(run_dir, frames, time_s, joints, poses, fps, up, shape, meta)


def sample_rate(run: Run) -> float:
    """Rows per second: ``fps`` divided by the (constant) step between frame numbers.

    Formats with an implicit time base (TRC DataRate, C3D, BVH) need evenly spaced rows; raises
    :class:`IPFError` otherwise.
    """
    steps = np.unique(np.diff(run.frames))
    require(len(steps) <= 1, "frame numbers are not evenly spaced "
            f"(steps {', '.join(map(str, steps[:5]))}); this format needs a constant rate",
            run.path / "joints.csv")
    return run.fps / (int(steps[0]) if len(steps) else 1)


# --------------------------------------------------------------------------------------------------
# Writing (tests, notebooks, and the tracker may reuse it)


def joints_from_poses(poses: np.ndarray, shape: BodyShape, up_axis: str) -> np.ndarray:
    """Reference forward kinematics of a trajectory.

    poses : (T, D) radians / metres; a row with any NaN is a missing frame.
    Returns (T, J, 3) metres, world frame, NaN rows for missing frames.
    """
    poses = np.asarray(poses, float)
    U = up_rotation(up_axis)
    out = np.full((len(poses), NUM_POINTS, 3), np.nan)
    for t, q in enumerate(poses):
        if np.all(np.isfinite(q)):
            out[t] = forward_kinematics(q, shape.values, U).points
    return out


def write_run_dir(run_dir: str | Path, poses: np.ndarray, *, shape: BodyShape | None = None,
                  up_axis: str = "+z", fps: float = 25.0, frames: np.ndarray | None = None,
                  meta: dict | None = None) -> Path:
    """Write a run directory whose joints are the forward kinematics of ``poses``.

    poses : (T, D) radians / metres; rows containing NaN are written as missing frames (all
    ``nan``) in both CSV files. frames : (T,) increasing ints, default ``0..T-1``;
    ``time_s = frame / fps``. shape : default adult when None. meta : extra run.json keys.
    Returns the directory (created if needed).
    """
    poses = np.asarray(poses, float)
    require(poses.ndim == 2 and poses.shape[1] == NUM_DOF,
            f"poses must be (T, {NUM_DOF}), got {poses.shape}")
    shape = default_shape() if shape is None else shape
    frames = np.arange(len(poses)) if frames is None else np.asarray(frames, np.int64)
    require(frames.shape == (len(poses),), "frames must have one entry per pose")
    run_dir = Path(run_dir)
    run_dir.mkdir(parents=True, exist_ok=True)
    missing = ~np.all(np.isfinite(poses), axis=1)
    poses = np.where(missing[:, None], np.nan, poses)
    joints = joints_from_poses(poses, shape, up_axis)
    time_s = frames / fps
    write_rows(run_dir / "joints.csv", JOINT_COLUMNS, frames, time_s,
                joints.reshape(len(poses), -1))
    write_rows(run_dir / "poses.csv", POSE_COLUMNS, frames, time_s, poses)
    doc = {"fps": float(fps), "up_axis": up_axis, "up_vector": axis_vector(up_axis).tolist(),
           "shape": shape.to_json(), **(meta or {})}
    (run_dir / "run.json").write_text(json.dumps(doc, indent=1))
    return run_dir
