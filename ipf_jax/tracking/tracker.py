"""The tracking loop (host side): frames -> masks -> filter step -> estimate -> files.

Per frame: read every camera's mask, resize it once to the scoring resolution, skip cameras with
an empty mask (recorded), write a missing row when no camera shows a person-sized blob (empty
masks, or specks only); otherwise run one filter step (or the automatic initialisation on the
first frame), watch the confidence (best weight over its recent median) and re-initialise when it
collapses. Rows are appended and fsynced per frame; a checkpoint every K frames makes
``resume=True`` continue exactly where a run stopped.

Before the first initialisation every camera with a silhouette must see the point on the floor
where the cameras' viewing rays meet: one that cannot (the point is behind it or far outside its
image) has a calibration that does not belong to its masks, and the run stops with an error naming
it rather than tracking on with a camera that can only ever score zero.
"""
from __future__ import annotations

import hashlib
import json
import time
from pathlib import Path
from typing import Callable, NamedTuple

import jax
import numpy as np
from tqdm import tqdm

from .. import __version__
from ..body.limits import Limits, limits_to_json, load_limits
from ..body.shape import BodyShape, default_shape, load_shape, shape_from_json
from ..data import checkpoint
from ..data.dataset import Dataset
from ..data.runfiles import (
    JOINT_COLUMNS,
    POSE_COLUMNS,
    CsvAppender,
    check_writable,
    write_json_atomic,
)
from ..data.silhouette import resize_mask
from ..errors import IPFError, require
from ..filters import registry
from ..filters.base import FilterState
from ..geometry.camera import Z_NEAR, Camera
from ..geometry.host import forward_kinematics, project_points
from ..geometry.rays import silhouette_rays
from ..geometry.world import AXES, detect_up_axis, up_rotation
from ..likelihood.scorer import (
    Observation,
    Scorer,
    make_observation,
    scoring_cameras,
    weights_from_counts,
)
from .contact import FloorContact
from .initialise import InitSettings, floor_points, initialise
from .origin import FrameAnchor, observe_anchor, root_shift

DEFAULT_RESOLUTION = 320  # long side of the scoring images, pixels
DEFAULT_FPS = 20.0  # the paper's rate
VIEW_MARGIN = 0.5  # of the image size: how far outside its image a camera may place the person
# (feet or head cut off by the border are common; a whole body half an image away is not)


class TrackSettings(NamedTuple):
    filter: str = "ipf"
    filter_options: dict = {}
    budget: int | None = None
    resolution: int = DEFAULT_RESOLUTION
    fps: float | None = None
    height_m: float | None = None
    shape_file: str | None = None
    limits: str = "default"
    up_axis: str | None = None
    seed: int = 0
    chunk: int = 512
    kernel: str = "scanline"
    checkpoint_every: int = 10
    confidence_drop: float = 0.5  # re-initialise below this fraction of the recent median weight...
    confidence_patience: int = 2  # ...for this many consecutive frames
    init: InitSettings = InitSettings()
    init_pose: np.ndarray | None = None
    origin_shift: bool = True  # body origin positioning from the silhouettes (see ipf_jax.tracking.origin)
    floor_range: tuple[float, float] | None = None  # floor contact (ipf_jax.tracking.contact); None = off


class FrameView(NamedTuple):
    """A tracked frame as the scorer saw it, for hooks (overlays): masks (C of (H, W) bool) and
    cameras at scoring resolution, the estimate ``pose`` (D,), its ``shape``, ``up`` (3, 3), weight."""

    frame: int
    masks: list
    cameras: list
    pose: np.ndarray
    shape: BodyShape
    up: np.ndarray
    weight: float | None


class RunResult(NamedTuple):
    out_dir: Path
    frames: list[int]
    poses: np.ndarray  # (T, D), nan rows for missing frames
    joints: np.ndarray  # (T, J, 3)
    run: dict


def check_cameras_see(foot: np.ndarray, up: np.ndarray, cameras: list[Camera],
                      numbers: list[int], where) -> None:
    """Raise IPFError naming the cameras that cannot see a person standing at ``foot``.

    foot : (3,) floor point (m);  up : (3,) world up;  numbers : 1-based camera numbers.
    The person is the vertical line from the floor to 1.5 m; a camera sees it when some point of
    it is in front of the camera and within :data:`VIEW_MARGIN` image sizes of its frame.
    """
    line = foot[None] + np.outer([0.0, 0.5, 1.0, 1.5], up)  # (4, 3)
    blind = []
    for k, cam in zip(numbers, cameras):
        uv, z, _ = project_points(cam, line)
        front = z > Z_NEAR
        near = ((uv[:, 0] >= -VIEW_MARGIN * cam.width) & (uv[:, 0] <= (1 + VIEW_MARGIN) * cam.width)
                & (uv[:, 1] >= -VIEW_MARGIN * cam.height) & (uv[:, 1] <= (1 + VIEW_MARGIN) * cam.height))
        if not np.any(front & near):
            blind.append((k, cam, "behind it" if not front.any() else "far outside its image"))
    if blind:
        k, cam, problem = blind[0]
        others = "".join(f"; camera {j} ({c.name}): {p}" for j, c, p in blind[1:])
        raise IPFError(f"camera {k} ({cam.name}) shows a silhouette, but the floor point "
                       f"({', '.join(f'{v:.2f}' for v in foot)}) m where the cameras' viewing rays meet "
                       f"is {problem}{others}: its calibration does not fit its masks (wrong file, "
                       "cameras in another order, or wrong --up)", cam.source or where)


def _settings_key(settings: TrackSettings, dataset: Dataset, frames: list[int]) -> str:
    doc = {k: (v if not isinstance(v, np.ndarray) else v.tolist()) for k, v in settings._asdict().items()}
    doc["init"] = settings.init._asdict()
    doc["dataset"] = str(dataset.path.resolve()) if dataset.layout != "memory" else dataset.name
    doc["frames"] = [frames[0], frames[-1], len(frames)] if frames else []
    return hashlib.sha256(json.dumps(doc, sort_keys=True, default=str).encode()).hexdigest()[:16]


class Tracker:
    """One tracking run over a dataset (see :func:`track`)."""

    def __init__(self, dataset: Dataset, settings: TrackSettings, frames: list[int] | None = None):
        self.dataset = dataset
        if settings.height_m is None and getattr(dataset, "height_m", None):
            settings = settings._replace(height_m=float(dataset.height_m))  # from dataset.json
        self.settings = settings
        self.frames = list(frames if frames is not None else dataset.frames)
        require(len(self.frames) > 0, "no frames to track (check --frames)")
        fps = settings.fps or dataset.fps or DEFAULT_FPS
        require(np.isfinite(fps) and fps > 0, f"frame rate must be > 0 (got {fps})")
        self.fps = float(fps)
        up = (settings.up_axis or dataset.up_axis
              or detect_up_axis(dataset.cameras, self.read_masks(self.frames[0])))
        require(up in AXES, f"unknown up axis {up!r} (choose one of {', '.join(AXES)})")
        self.up_axis = up
        self.U = up_rotation(up)
        self.limits: Limits = load_limits(settings.limits)
        self.base_shape: BodyShape = (default_shape() if settings.shape_file is None
                                      else load_shape(settings.shape_file))
        self.cameras, self.scales = scoring_cameras(dataset.cameras, settings.resolution)
        self.filter_hook = None  # optional Filter -> Filter wrapper (e.g. compare's step timing)
        self.filter = self.make_filter(None)
        self.scorer = Scorer(self.cameras, self.base_shape, self.U, kernel=settings.kernel,
                             chunk=settings.chunk)
        self.key = jax.random.PRNGKey(settings.seed)

    def make_filter(self, shape: BodyShape | None):
        """The filter; once the subject's shape is known its limits include floor contact."""
        s = self.settings
        limits = self.limits
        if shape is not None and s.floor_range is not None:
            limits = FloorContact(self.limits, shape, self.U, *s.floor_range)
        f = registry.make(s.filter, s.filter_options, limits, self.fps, budget=s.budget)
        return f if self.filter_hook is None else self.filter_hook(f)

    # -- per frame helpers -------------------------------------------------------------------
    def read_masks(self, frame: int) -> list[np.ndarray]:
        masks = self.dataset.masks(frame)
        for k, m in enumerate(masks, start=1):
            # float masks (arrays, 32-bit TIFF) can hold NaN, which is neither foreground nor
            # background: refusing it beats silently counting it as foreground
            if np.asarray(m).dtype.kind == "f" and np.isnan(m).any():
                raise IPFError(f"mask of camera {k} has {int(np.isnan(m).sum())} NaN pixels on frame "
                               f"{frame}", self.dataset.path)
        return masks

    def observe(self, frame: int) -> tuple[Observation, list[np.ndarray]]:
        masks = self.read_masks(frame)
        small = [m if s == 1.0 else resize_mask(m, c.height, c.width)
                 for m, s, c in zip(masks, self.scales, self.cameras)]
        return make_observation(small), small

    def measure(self, obs: Observation, shape: BodyShape | None = None):
        def fn(particles: np.ndarray, shp: BodyShape | None = None) -> np.ndarray:
            s = shp or shape
            if s is not None and s is not self.scorer.shape:
                self.scorer.set_shape(s)
            return weights_from_counts(self.scorer.counts(particles, obs), obs.active)[0]
        return fn

    def frame_key(self, frame: int, salt: int = 0) -> jax.Array:
        return jax.random.fold_in(jax.random.fold_in(self.key, frame), salt)

    def check_view(self, obs: Observation, small: list[np.ndarray]) -> None:
        """Every camera with a silhouette sees where the person stands (see module doc)."""
        active = [i for i in range(len(small)) if obs.active[i]]
        height = self.settings.height_m or self.base_shape.height_m
        foot = floor_points([small[i] for i in active], [self.cameras[i] for i in active],
                            self.U[:, 2], (height,))[height]
        check_cameras_see(foot, self.U[:, 2], [self.dataset.cameras[i] for i in active],
                          [i + 1 for i in active], self.dataset.path)

    def initialise(self, frame: int, obs: Observation, small: list[np.ndarray],
                   shape: BodyShape | None) -> tuple[np.ndarray, np.ndarray, BodyShape, int]:
        """Particles, weights, subject shape and evaluations; ``shape`` given = re-initialisation."""
        s = self.settings
        active = [i for i in range(len(small)) if obs.active[i]]
        if s.init_pose is not None and shape is None:
            shape = self.base_shape if s.height_m is None else self.base_shape.scaled_to(s.height_m)
            q = self.limits.clip(np.asarray(s.init_pose, float)[None])
            w = self.measure(obs, shape)(q)
            return q, w, shape, 1
        res = initialise(self.frame_key(frame, 1), [small[i] for i in active],
                         [self.cameras[i] for i in active], self.U, self.limits, self.base_shape,
                         self.measure(obs), height_m=s.height_m, fixed_shape=shape, settings=s.init)
        return res.particles, res.weights, res.shape, res.evaluations

    # -- the loop ----------------------------------------------------------------------------
    def run(self, out_dir: Path, *, resume: bool = False, progress: bool = True,
            frame_hook: Callable[[FrameView], None] | None = None) -> RunResult:
        out_dir = check_writable(Path(out_dir))
        key = _settings_key(self.settings, self.dataset, self.frames)
        if resume:
            ck = checkpoint.load(out_dir)
            if ck.settings_key != key:
                raise IPFError("cannot resume: the run in this folder used other settings or data",
                               out_dir)
            for stale in [*out_dir.glob(f"{checkpoint.NAME}*.tmp"), *out_dir.glob("run.json*.tmp")]:
                stale.unlink(missing_ok=True)  # left by a kill during an atomic write
        else:
            ck = checkpoint.Checkpoint(0, 0, None, None, None, [], 0, [], [], 0, key, None, 0.9)
        joints_csv = CsvAppender(out_dir / "joints.csv", JOINT_COLUMNS, ck.rows if resume else None,
                                 lazy=True)
        poses_csv = CsvAppender(out_dir / "poses.csv", POSE_COLUMNS, ck.rows if resume else None,
                                lazy=True)
        state = None if ck.particles is None else FilterState(ck.particles, ck.weights)
        shape = None if ck.shape is None else shape_from_json(ck.shape)
        self.filter = self.make_filter(shape)
        history, low_streak = list(ck.history), ck.low_streak
        per_frame, reinits = list(ck.per_frame), list(ck.reinits)
        init_evals = ck.init_evaluations
        prev_anchor = FrameAnchor.from_json(ck.anchor)
        anchor_height = ck.anchor_height
        rows = ck.rows
        t_start = time.perf_counter()
        bar = tqdm(self.frames[ck.next_index:], desc=f"track {self.dataset.name}", unit="frame",
                   disable=not progress, initial=0, leave=True)
        frame = None
        try:
            for idx, frame in enumerate(bar, start=ck.next_index):
                t0 = time.perf_counter()
                obs, small = self.observe(frame)
                time_s = frame / self.fps
                skipped = [self.dataset.cameras[i].name for i in range(len(small)) if not obs.active[i]]
                rec = {"frame": int(frame), "time_s": round(time_s, 6), "skipped_cameras": skipped}
                # specks alone (no blob of a person's size in any camera) cannot place anyone
                if not silhouette_rays([m for m, a in zip(small, obs.active) if a],
                                       [c for c, a in zip(self.cameras, obs.active) if a]):
                    nan = np.full(len(JOINT_COLUMNS) - 2, np.nan)
                    joints_csv.write(frame, time_s, nan)
                    poses_csv.write(frame, time_s, np.full(len(POSE_COLUMNS) - 2, np.nan))
                    rec.update(status="missing", weight=None, confidence=None, evaluations=0)
                else:
                    status = "tracked"
                    here = observe_anchor(list(small), self.cameras, self.U[:, 2],
                                          (shape or self.base_shape).height_m)
                    shift = (root_shift(prev_anchor, here, self.U[:, 2], anchor_height)
                             if self.settings.origin_shift else np.zeros(3))
                    prev_anchor = here
                    if state is None:
                        self.check_view(obs, small)
                        q, w, shape, n = self.initialise(frame, obs, small, None)
                        self.filter = self.make_filter(shape)
                        init_evals += n
                        state = self.filter.init(q, w)
                        status, evals = "init", 0
                    else:
                        state = FilterState(state.particles + np.r_[shift, np.zeros(state.particles.shape[1] - 3)],
                                            state.weights)
                        state, info = self.filter.step(self.frame_key(frame), state,
                                                       self.measure(obs, shape))
                        evals = info.evaluations
                    best = int(np.nanargmax(state.weights))
                    w_best = float(state.weights[best])
                    ref = float(np.median(history)) if history else w_best
                    conf = w_best / ref if ref > 0 else 0.0
                    low_streak = low_streak + 1 if conf < self.settings.confidence_drop else 0
                    if status == "tracked" and low_streak >= self.settings.confidence_patience:
                        try:
                            q, w, _, n = self.initialise(frame, obs, small, shape)
                        except IPFError as e:  # a recovery attempt that cannot run keeps the track
                            w, n = None, 0
                            rec["reinit_error"] = e.message
                        init_evals += n
                        reinits.append(int(frame))
                        if w is not None and np.nanmax(w) > w_best:
                            state = self.filter.init(q, w)
                            best = int(np.nanargmax(state.weights))
                            w_best = float(state.weights[best])
                            status = "reinit"
                        else:
                            status = "reinit-rejected"
                        history, low_streak = [], 0
                        conf = 1.0
                    history = (history + [w_best])[-10:]
                    q_best = state.particles[best]
                    pts = forward_kinematics(q_best, shape.values, self.U).points
                    if status == "init":  # one plane for the whole run (single camera, see origin)
                        anchor_height = float(self.U[:, 2] @ pts[0])
                    joints_csv.write(frame, time_s, pts.ravel())
                    poses_csv.write(frame, time_s, q_best)
                    rec.update(status=status, weight=round(w_best, 6), confidence=round(conf, 4),
                               evaluations=int(evals), origin_shift_m=round(float(np.linalg.norm(shift)), 4))
                rows += 1
                rec["seconds"] = round(time.perf_counter() - t0, 4)
                per_frame.append(rec)
                bar.set_postfix(w=rec.get("weight"), conf=rec.get("confidence"))
                done = idx + 1
                if done % self.settings.checkpoint_every == 0 or done == len(self.frames):
                    checkpoint.save(out_dir, checkpoint.Checkpoint(
                        done, rows, None if state is None else state.particles,
                        None if state is None else state.weights,
                        None if shape is None else shape.to_json(), history, low_streak,
                        per_frame, reinits, init_evals, key,
                        None if prev_anchor is None else prev_anchor.to_json(), anchor_height))
                    write_json_atomic(out_dir / "run.json", self.run_doc(per_frame, reinits, init_evals,
                                                                        shape, time.perf_counter() - t_start))
                if frame_hook is not None and rec["status"] != "missing":
                    frame_hook(FrameView(frame, small, self.cameras, state.particles[best], shape,
                                         self.U, rec["weight"]))
        except IPFError as e:  # say where the run stopped and that its rows are safe
            hint = ("; rows written so far are kept: fix it and rerun with --resume"
                    if (out_dir / checkpoint.NAME).exists() else "")
            raise IPFError(f"{e.message} (at frame {frame}{hint})", e.path) from None
        finally:
            bar.close()
            joints_csv.close()
            poses_csv.close()
        doc = self.run_doc(per_frame, reinits, init_evals, shape, time.perf_counter() - t_start)
        write_json_atomic(out_dir / "run.json", doc)
        from ..data.runfiles import read_joints_csv

        table = read_joints_csv(out_dir / "joints.csv")
        poses = np.genfromtxt(out_dir / "poses.csv", delimiter=",", skip_header=1, ndmin=2)[:, 2:]
        return RunResult(out_dir, self.frames, poses, table.points, doc)

    def run_doc(self, per_frame, reinits, init_evals, shape, seconds) -> dict:
        s = self.settings
        tracked = [r for r in per_frame if r["status"] != "missing"]
        shape = shape or self.base_shape
        return {
            "ipf_jax_version": __version__, "jax_version": jax.__version__,
            "device_kind": jax.devices()[0].device_kind,
            "dataset": str(self.dataset.path), "layout": self.dataset.layout,
            "cameras": [c.name for c in self.dataset.cameras],
            "filter": self.filter.name, "filter_params": self.filter.params,
            "settings": {"resolution": s.resolution, "scoring_sizes": [[c.width, c.height] for c in self.cameras],
                         "limits": s.limits, "seed": s.seed, "kernel": s.kernel, "chunk": s.chunk,
                         "budget": s.budget, "height_m_given": s.height_m,
                         "confidence_drop": s.confidence_drop,
                         "confidence_patience": s.confidence_patience, "init": s.init._asdict(),
                         "floor_range_m": s.floor_range, "origin_shift": s.origin_shift},
            "limits": limits_to_json(self.limits),
            "fps": self.fps, "up_axis": self.up_axis, "up_vector": self.U[:, 2].tolist(), "units": "m",
            "height_m": shape.height_m, "shape": shape.to_json(),
            "frames": {"first": self.frames[0], "last": self.frames[-1], "count": len(self.frames),
                       "done": len(per_frame), "missing": sum(r["status"] == "missing" for r in per_frame)},
            "evaluations_per_frame": self.filter.evaluations_per_frame,
            "init_evaluations": init_evals,
            "reinitialisations": reinits,
            "seconds": {"total": round(seconds, 3),
                        "per_tracked_frame_mean": round(float(np.mean(
                            [r["seconds"] for r in tracked if r["status"] == "tracked"] or [np.nan])), 4)},
            "per_frame": per_frame,
        }


def track(dataset: Dataset, out_dir: str | Path, settings: TrackSettings = TrackSettings(), *,
          frames: list[int] | None = None, resume: bool = False, progress: bool = True,
          frame_hook: Callable[[FrameView], None] | None = None) -> RunResult:
    """Track ``dataset`` into ``out_dir`` (joints.csv, poses.csv, run.json). See module doc.

    frame_hook : called after every frame with a person, with the frame's :class:`FrameView`
        (e.g. :func:`ipf_jax.viz.overlay.overlay_writer` writes overlay PNGs: ``track --overlay``).
    """
    return Tracker(dataset, settings, frames).run(Path(out_dir), resume=resume, progress=progress,
                                                  frame_hook=frame_hook)
