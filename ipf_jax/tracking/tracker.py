"""The tracker: one frame at a time, observe -> place -> (initialise | select, predict, measure) ->
estimate -> check, then write the rows.

:meth:`Tracker.track_frame` is one frame, ``(state, frame) -> (state, FrameRecord)``, and reads as
the paper's stages; :class:`~ipf_jax.tracking.state.TrackState` is everything carried from frame to
frame and is the checkpoint. :meth:`Tracker.run` only reads frames (the next one on a
background thread while this one is tracked: :mod:`.prefetch`), writes rows (appended and flushed
per frame, fsynced before each checkpoint), checkpoints every K frames and shows progress, so
``resume=True`` continues exactly where a run stopped: the state saved on a stop is the one before
the frame whose rows were not yet written, however late in that frame the stop lands.

Per frame: every camera's mask is resized once to the scoring resolution; a camera with an empty
mask is skipped (recorded); a frame where no camera shows a person-sized blob is written as
missing. Otherwise the body origin moves with the silhouettes (:mod:`.origin`), the filter steps
(or, on the first frame, the automatic initialisation runs: :mod:`.initialise`), the heaviest
particle is the estimate, and a confidence (best weight over its recent median) that collapses for
a few frames triggers a re-initialisation, kept only if it explains the silhouettes better.

Before the first initialisation every camera with a silhouette must see the point on the floor
where the cameras' viewing rays meet: one that cannot (the point is behind it or far outside its
image) has a calibration that does not belong to its masks, and the run stops with an error naming
it rather than tracking on with a camera that can only ever score zero.
"""
from __future__ import annotations

import hashlib
import json
import statistics
import threading
import time
import warnings
from pathlib import Path
from typing import Callable, NamedTuple

import jax
import numpy as np
from tqdm import tqdm

from .. import __version__, stop
from ..jax_setup import host_cpu
from ..body.limits import Limits, limits_to_json, load_limits
from ..body.model import DOF_NAMES, NUM_DOF, NUM_POINTS
from ..body.shape import BodyShape, default_shape, load_shape
from ..data import checkpoint
from ..data.background_model import frame_quality, quality_summary
from ..data.dataset import Dataset
from ..data.runfiles import (
    JOINT_COLUMNS,
    POSE_COLUMNS,
    CsvAppender,
    EncodedList,
    check_writable,
    read_joints_csv,
    read_table,
    write_json_atomic,
)
from ..data.silhouette import resize_mask
from ..errors import IPFError, IPFWarning, require
from ..filters import registry
from ..filters.base import Filter, best_index
from ..filters.posture import Body
from ..geometry.camera import Z_NEAR, Camera
from ..geometry.host import joint_points, project_points
from ..geometry.placement import HEIGHT_MIN_FRAMES, height_from_view
from ..geometry.rays import blobs, camera_rays
from ..geometry.world import AXES, contradicted_up, detect_up_axis, up_rotation
from ..likelihood.scorer import (
    Observation,
    Scorer,
    make_observation,
    pick_chunking,
    scoring_cameras,
    weights_from_counts,
)
from ..lowered import Program
from . import loss
from . import state as track_state
from .contact import FloorContact
from .initialise import InitSettings, floor_points, initialise
from .loss import Coverage, coverage
from .options import settings_doc
from .origin import FrameAnchor, observe_anchor, root_shift
from .prefetch import Prefetch
from .prior import level_pelvis, upright_to_camera
from .recovery import GLOBAL, recover
from .settings import DEFAULT_FPS, DEFAULT_RESOLUTION, TrackSettings, init_settings
from .shape_fit import Scene, calibrate_at_start, shape_doc, spread_frames
from .state import HISTORY, FrameRecord, TrackState
from .travel import travel_heading, window_frames

__all__ = ["DEFAULT_FPS", "DEFAULT_RESOLUTION", "FrameView", "RunResult", "TrackSettings", "Tracker",
           "track"]

#: A mask with more of its image foreground than this shows no silhouette (a background model
#: that failed, a light switched on): that camera is skipped on that frame, like an empty one.
#: A person filling a camera's view from head to toe covers far less (the renders: 3-8 %).
FULL_MASK_SHARE = 0.9


def is_full(mask: np.ndarray) -> bool:
    """Whether more than :data:`FULL_MASK_SHARE` of the mask is foreground."""
    return np.count_nonzero(mask) > FULL_MASK_SHARE * np.asarray(mask).size


def without_full(mask: np.ndarray) -> np.ndarray:
    """The mask, or an empty one in its place when it is full (:func:`is_full`)."""
    return np.zeros(np.shape(mask), bool) if is_full(mask) else mask


#: one camera, no height given: frames the height is measured on, and the largest spread (90th -
#: 10th percentile of the per-frame estimates) of a person who stays upright (the visible
#: one-camera walks: 0.08-0.11 m; sit-to-stand: 0.58-0.63 m)
HEIGHT_FRAMES = 15
HEIGHT_SPREAD_M = 0.15
VIEW_MARGIN = 0.5  # of the image size: how far outside its image a camera may place the person
# (feet or head cut off by the border are common; a whole body half an image away is not)


class Seen(NamedTuple):
    """One frame as the cameras saw it: ``obs`` for the scorer, ``masks`` (C of (H, W) bool) at
    scoring resolution, whether anyone is there (a person-sized blob in some camera), the
    masks' quality figures (:func:`ipf_jax.data.background_model.frame_quality`) and each
    camera's ray through its largest blob (:func:`~ipf_jax.geometry.rays.camera_rays`, None
    where it sees no one)."""

    obs: Observation
    masks: list
    person: bool
    quality: list
    rays: list


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


def median(values) -> float:
    """``np.median`` of a few floats, the same number (NaN when one is NaN, where
    :func:`statistics.median`'s sort has no order), without its ~0.1 ms of array overhead (every
    tracked frame takes the median of its last weights)."""
    v = [float(x) for x in values]
    return float("nan") if any(x != x for x in v) else statistics.median(v)


@Program  # a jit whose lowering is kept on disk (ipf_jax.lowered)
def frame_key(key: jax.Array, frame: int, salt: int) -> jax.Array:
    """The key of stage ``salt`` of ``frame``: ``fold_in(fold_in(key, frame), salt)``, in one
    compiled call (the eager pair dispatched ~40 primitives, 1-2 ms a frame under a profiler)."""
    return jax.random.fold_in(jax.random.fold_in(key, frame), salt)


def settings_key(settings: TrackSettings, dataset: Dataset, frames: list[int]) -> str:
    """A digest of what a run's files depend on: a checkpoint resumes only under the same key."""
    doc = {k: (v if not isinstance(v, np.ndarray) else v.tolist()) for k, v in settings._asdict().items()}
    doc["filter_options"] = dict(settings.filter_options)
    doc["init"] = settings.init._asdict()
    doc["dataset"] = str(dataset.path.resolve()) if dataset.layout != "memory" else dataset.name
    doc["frames"] = [frames[0], frames[-1], len(frames)] if frames else []
    return hashlib.sha256(json.dumps(doc, sort_keys=True, default=str).encode()).hexdigest()[:16]


class Tracker:
    """One tracking run over a dataset (see :func:`track`): the static context of every frame
    (cameras at scoring resolution, up axis, limits, template body, scorer, seed)."""

    def __init__(self, dataset: Dataset, settings: TrackSettings, frames: list[int] | None = None):
        self.dataset = dataset
        self._read_lock = threading.Lock()  # one read of the data set at a time (see run)
        if settings.height_m is None and getattr(dataset, "height_m", None):
            settings = settings._replace(height_m=float(dataset.height_m))  # from dataset.json
        self.settings = settings
        self.frames = list(frames if frames is not None else dataset.frames)
        require(len(self.frames) > 0, "no frames to track (check --frames)")
        fps = settings.fps or dataset.fps or DEFAULT_FPS
        require(np.isfinite(fps) and fps > 0, f"frame rate must be > 0 (got {fps})")
        self.fps = float(fps)
        up = dataset.up_axis if settings.up_axis is None else settings.up_axis
        up = self._up_axis(up, given=settings.up_axis is not None)
        require(up in AXES, f"unknown up axis {up!r} (choose one of {', '.join(AXES)})")
        self.up_axis = up
        self.U = up_rotation(up)
        self.height_measured = None  # run.json: the one-camera height measurement, when made
        if settings.height_from_view:
            skip = ("a height is given" if settings.height_m is not None
                    else "a shape file is given" if settings.shape_file is not None
                    else "an initial pose is given" if settings.init_pose is not None
                    else f"it measures with one camera, not {len(dataset.cameras)}"
                    if len(dataset.cameras) != 1 else None)
            if skip is not None:
                warnings.warn(f"--height-from-view: not measured ({skip})", IPFWarning, stacklevel=2)
            else:
                self.height_measured = got = self.measure_height()
                if got["not_used"] is None:
                    settings = self.settings = settings._replace(height_m=got["height_m"])
                else:
                    warnings.warn(f"--height-from-view: not used ({got['not_used']}); the height is "
                                  "searched", IPFWarning, stacklevel=2)
        self.limits: Limits = load_limits(settings.limits)
        self.base_shape: BodyShape = (default_shape() if settings.shape_file is None
                                      else load_shape(settings.shape_file))
        if settings.shape_file is not None and settings.height_m is not None:  # a file fixes the body
            require(abs(settings.height_m - self.base_shape.height_m) <= 0.01,
                    f"height {settings.height_m:.3f} m (--height or dataset.json) disagrees with the "
                    f"shape file's {self.base_shape.height_m:.3f} m by more than 1 cm",
                    settings.shape_file)
        self.cameras, self.scales = scoring_cameras(dataset.cameras, settings.resolution)
        self.filter_hook = None  # optional Filter -> Filter wrapper (e.g. compare's step timing)
        self._filters: dict[int, tuple[BodyShape | None, Filter]] = {}
        self._ahead: dict[int, tuple[jax.Array, object]] = {}  # see draw_ahead
        # padding against calls and programs: docs/benchmarks.md
        chunk, block = pick_chunking(self.filter.calls, chunk=settings.chunk)
        self.scorer = Scorer(self.cameras, self.base_shape, self.U, kernel=settings.kernel,
                             chunk=chunk, block=block, threads=settings.threads)
        self.key = jax.random.PRNGKey(settings.seed)

    def measure_height(self) -> dict:
        """The standing height from the one camera's silhouettes on :data:`HEIGHT_FRAMES` frames
        spread over the run (:func:`~ipf_jax.geometry.placement.height_from_view`); used when
        the per-frame estimates agree within :data:`HEIGHT_SPREAD_M` (an upright person: a walker's
        head bobs by a few cm, someone sitting down or bending moves it by decimetres). Its
        ``not_used`` says why it is not used (None: it is)."""
        picks = spread_frames(self.frames, HEIGHT_FRAMES)
        masks = [without_full(self.read_masks(f)[0]) for f in picks]
        h, est = height_from_view(self.dataset.cameras[0], masks, self.U[:, 2])
        good = est[np.isfinite(est)]
        spread = float(np.percentile(good, 90) - np.percentile(good, 10)) if len(good) else None
        if not np.isfinite(h):
            why = (f"{len(good)} of {len(picks)} frames usable, {HEIGHT_MIN_FRAMES} needed: the "
                   "person whole in the image, seen by a camera above the floor, not rolled on its "
                   "side, at most 45 deg down")
        elif spread > HEIGHT_SPREAD_M:
            why = f"the estimates spread over {spread:.2f} m: the person does not stay upright"
        elif not 1.0 <= h <= 2.4:
            why = f"{h:.2f} m is not a person's height"
        else:
            why = None
        return {"height_m": round(float(h), 3) if np.isfinite(h) else None, "not_used": why,
                "frames": [int(f) for f in picks], "usable_frames": int(len(good)),
                "spread_m": None if spread is None else round(spread, 3)}

    @property
    def filter(self) -> Filter:
        """The filter before the subject is known (its name, parameters, budget)."""
        return self.filter_for(None)

    def filter_for(self, shape: BodyShape | None) -> Filter:
        """The filter for the subject's ``shape`` (None: before it is known, the template's body
        stands in): its posture group holds that body's feet (:mod:`ipf_jax.filters.posture`),
        its limits include floor contact when asked for."""
        k = 0 if shape is None else id(shape)
        if k not in self._filters or self._filters[k][0] is not shape:  # an id can be reused
            s = self.settings
            contact = shape is not None and s.floor_range is not None
            limits = FloorContact(self.limits, shape, self.U, *s.floor_range) if contact else self.limits
            body = Body(np.asarray((shape or self.base_shape).values, np.float64),
                        np.asarray(self.U, np.float64))
            f = registry.make(s.filter, s.filter_options, limits, self.fps, budget=s.budget, body=body,
                              views=len(self.cameras))
            self._filters = {0: self._filters.get(0, (None, f)), k: (shape, f)}
        f = self._filters[k][1]
        return f if self.filter_hook is None else self.filter_hook(f)

    # -- the stages of a frame ---------------------------------------------------------------
    def _up_axis(self, up: str | None, given: bool) -> str:
        """``up`` (a given one checked against the cameras: a warning when they clearly show
        another, :func:`~ipf_jax.geometry.world.contradicted_up`), else the detected one."""
        if up is not None and not given:
            return up  # the dataset's own
        masks = [without_full(m) for m in self.read_masks(self.frames[0])]
        if up is None:
            return detect_up_axis(self.dataset.cameras, masks)
        seen = contradicted_up(self.dataset.cameras, masks, up)  # (an unknown axis: IPFError)
        if seen is not None:
            warnings.warn(f"up axis {up} given, but the cameras show {seen} as up (the body would be "
                          f"tracked on its side or head): is the up axis {seen}?", IPFWarning, stacklevel=3)
        return up

    def read_masks(self, frame: int) -> list[np.ndarray]:
        with self._read_lock:  # the next frame may be read on another thread (run, .prefetch)
            masks = self.dataset.masks(frame)
        for k, m in enumerate(masks, start=1):
            # float masks (arrays, 32-bit TIFF) can hold NaN, which is neither foreground nor
            # background: refusing it beats silently counting it as foreground
            if np.asarray(m).dtype.kind == "f" and np.isnan(m).any():
                raise IPFError(f"mask of camera {k} has {int(np.isnan(m).sum())} NaN pixels on frame "
                               f"{frame}", self.dataset.path)
        return masks

    def observe(self, frame: int) -> Seen:
        """The frame's masks at scoring resolution; specks alone (no blob of a person's size in
        any camera) are nobody."""
        masks = self.read_masks(frame)
        small = [m if s == 1.0 else resize_mask(m, c.height, c.width)
                 for m, s, c in zip(masks, self.scales, self.cameras)]
        # one connected-components pass per mask for the rays and the quality figures (theirs
        # agree for bool masks: nonzero as uint8 is the bool mask)
        found = [blobs(m) if m.dtype == bool else None for m in small]
        quality = frame_quality(small, [None if f is None else f[0] for f in found])
        full = [is_full(m) for m in small]
        if any(full):  # no silhouette in it (a failed background model): the camera sits out
            small = [np.zeros(m.shape, bool) if f else m for m, f in zip(small, full)]
            found = [None if f else b for f, b in zip(full, found)]
        obs = make_observation(small)
        rays = camera_rays(small, self.cameras, found)  # None for every camera without a blob
        person = any(r is not None for r in rays)
        return Seen(obs, small, person, quality, rays)

    @property
    def lean_prior(self):
        """``fn(particles (N, D), shape values (P,) or (N, P)) -> (N,)`` factors of the prior that
        the person stands upright along the line of sight of the one camera (:mod:`.prior`);
        None with several cameras or ``lean_prior_deg`` 0."""
        sigma = self.settings.lean_prior_deg
        if sigma <= 0 or len(self.cameras) != 1:
            return None
        centre = self.cameras[0].centre
        return lambda particles, values: upright_to_camera(particles, values, self.U, centre, sigma)

    def measure(self, obs: Observation, shape: BodyShape | None = None, log: list | None = None,
                pad: bool = False):
        """``fn(particles, shape=None) -> weights`` on ``obs`` (times the priors, :mod:`.prior`);
        with ``log`` every call's particles and counts are appended to it (the loss test reads the
        estimate's there); ``pad``: see :meth:`~ipf_jax.likelihood.scorer.Scorer.counts`."""
        lean = self.lean_prior

        def fn(particles: np.ndarray, shp: BodyShape | None = None) -> np.ndarray:
            s = shp or shape
            if s is not None and s is not self.scorer.shape:
                self.scorer.set_shape(s)
            counts = self.scorer.counts(particles, obs, pad=pad)
            if log is not None:
                log.append((np.asarray(particles), counts))
            w = weights_from_counts(counts, obs.active)[0]
            if self.settings.pelvis_prior_deg > 0:  # a weak prior that the pelvis is level
                w = w * level_pelvis(particles, self.settings.pelvis_prior_deg)
            if lean is not None:  # upright along one camera's line of sight
                w = w * lean(particles, (s or self.scorer.shape).values)
            return w
        return fn

    def coverage_of(self, pose: np.ndarray, obs: Observation, shape: BodyShape, log: list) -> Coverage:
        """The per-camera shares of ``pose`` (:mod:`.loss`), from its counts in ``log`` when this
        frame scored it (it almost always did), else scored once more (appended to ``log``)."""
        for particles, counts in reversed(log):
            same = np.flatnonzero(particles[:, 0] == pose[0])  # one column, then those rows whole
            hit = same[(particles[same] == pose).all(1)]
            if hit.size:
                return coverage(counts[hit[0]], obs.active)
        self.measure(obs, shape, log)(pose[None])
        return coverage(log[-1][1][0], obs.active)

    def frame_key(self, frame: int, salt: int = 0) -> jax.Array:
        return frame_key(self.key, np.uint32(frame), np.uint32(salt))

    def floor_point(self, obs: Observation, small: list[np.ndarray]) -> np.ndarray:
        """(3,) the floor point under the person seen by the active cameras (the given or the
        template's height for one camera); IPFError when no camera sees anyone."""
        active = [i for i in range(len(small)) if obs.active[i]]
        height = self.settings.height_m or self.base_shape.height_m
        return floor_points([small[i] for i in active], [self.cameras[i] for i in active],
                            self.U[:, 2], (height,))[height]

    def check_view(self, obs: Observation, small: list[np.ndarray]) -> None:
        """Every camera with a silhouette sees where the person stands (see module doc)."""
        active = [i for i in range(len(small)) if obs.active[i]]
        check_cameras_see(self.floor_point(obs, small), self.U[:, 2],
                          [self.dataset.cameras[i] for i in active], [i + 1 for i in active],
                          self.dataset.path)

    def heading_of_travel(self, frame: int) -> float | None:
        """The direction (rad) the silhouettes' floor point travels from ``frame`` over about a
        second (:mod:`.travel`), or None: standing still, turning, or ``--no-facing-travel``."""
        if not self.settings.facing_travel:
            return None
        points = []
        for f in window_frames(self.frames, frame, self.fps):
            try:
                points.append(self.floor_point(*self.observe(f)[:2]))
            except IPFError:  # nobody seen on that frame: no direction from it
                continue
        return travel_heading(points, self.U)

    def initialise(self, frame: int, obs: Observation, small: list[np.ndarray],
                   shape: BodyShape | None, log: list | None = None) -> tuple[np.ndarray, np.ndarray, BodyShape, int]:
        """Particles, weights, subject shape and evaluations; ``shape`` given = re-initialisation.
        ``log``: see :meth:`measure`."""
        s = self.settings
        active = [i for i in range(len(small)) if obs.active[i]]
        if s.init_pose is not None and shape is None:
            shape = self.base_shape if s.height_m is None else self.base_shape.scaled_to(s.height_m)
            q = self.limits.clip(np.asarray(s.init_pose, float)[None])
            self._check_within_limits(np.asarray(s.init_pose, float), "the initial pose (--init-pose)")
            # one pose, in a block as the filter's calls run (no program loaded for it alone)
            w = self.measure(obs, shape, log, pad=True)(q)
            return q, w, shape, 1
        if shape is None and s.shape_file is not None:  # a shape file fixes the body
            shape = self.base_shape
        res = initialise(self.frame_key(frame, 1), [small[i] for i in active],
                         [self.cameras[i] for i in active], self.U, self.limits, self.base_shape,
                         self.measure(obs, log=log), height_m=s.height_m, fixed_shape=shape,
                         settings=s.init, heading=self.heading_of_travel(frame))
        return res.particles, res.weights, res.shape, res.evaluations

    def fit_scene(self) -> Scene:
        """What the shape fit needs from this run (:class:`~ipf_jax.tracking.shape_fit.Scene`),
        its scores weighted by the lean prior as the tracker's are."""
        return Scene(lambda f: tuple(self.observe(f)[:2]), self.frames, self.cameras, self.U,
                     self.limits, self.scorer, self.frame_key, self.heading_of_travel, self.lean_prior)

    def calibrate(self, frame: int, q: np.ndarray, w: np.ndarray, shape: BodyShape):
        """The subject's proportions fitted with the poses of frames spread over the recording
        (:func:`ipf_jax.tracking.shape_fit.calibrate_at_start`); returns the first frame's
        particles, weights, the shape and the fit's record."""
        s = self.settings
        scene = self.fit_scene()
        light = {} if s.init == init_settings() else {"frame_init": s.init}  # --init-budget small
        q, w, shape, _, doc = calibrate_at_start(scene, frame, q, w, shape, height_m=s.height_m,
                                                 settings=s.shape_fit, seed=s.seed, **light)
        self.scorer.set_shape(shape)
        return q, w, shape, doc

    def place(self, state: TrackState, seen: Seen) -> tuple[FrameAnchor, np.ndarray]:
        """Body origin positioning: the frame's silhouette anchor, and the (3,) root shift since
        the last frame (zero when positioning is off or cannot be measured)."""
        here = observe_anchor(list(seen.masks), self.cameras, self.U[:, 2],
                              (state.shape or self.base_shape).height_m, seen.rays)
        shift = (root_shift(state.anchor, here, self.U[:, 2], state.anchor_height)
                 if self.settings.origin_shift else np.zeros(3))
        return here, shift

    def start(self, state: TrackState, frame: int, seen: Seen, log: list | None = None) -> TrackState:
        """The automatic initialisation (or the given initial pose) on the first frame seen."""
        s = self.settings
        self.check_view(seen.obs, seen.masks)
        q, w, shape, n = self.initialise(frame, seen.obs, seen.masks, None, log=log)
        require(s.init_pose is None or bool(np.nanmax(w) > 0),
                f"the initial pose (--init-pose) lies off every camera's silhouette on frame {frame} "
                "(weight 0): is it in this dataset's world coordinates and units (metres, the "
                "dataset's up axis)?")
        self._check_within_limits(q[best_index(w)])
        doc = None
        if s.shape_fit.frames > 0 and s.init_pose is None and s.shape_file is None:
            q, w, shape, doc = self.calibrate(frame, q, w, shape)  # its cost is in its record
        self.scorer.reset_windows()  # the search's spread is not the tracked frames'
        return state._replace(filter=self.filter_for(shape).init(q, w), shape=shape,
                              init_evaluations=state.init_evaluations + n, shape_fit=doc)

    def _check_within_limits(self, pose: np.ndarray, what: str = "the first pose found") -> None:
        """One warning when ``pose`` lies outside the limits (e.g. a limits file whose root range
        excludes where the silhouettes put the person: the floor placement wins; or a given
        initial pose that the limits clamp; a heading is wrapped, not out of range)."""
        lo, hi = self.limits.lower, self.limits.upper
        pose = self.limits.wrap(pose)
        bad = np.flatnonzero(self.limits.outside(pose))
        if len(bad):
            warnings.warn(IPFWarning(
                f"{what} lies outside the limits ({self.limits.name}) in "
                f"{', '.join(DOF_NAMES[i] for i in bad)}: " + ", ".join(
                    f"{DOF_NAMES[i]} {pose[i]:.3f} not in {lo[i]:.3f}..{hi[i]:.3f}" for i in bad[:3])
                + " (radians / metres): do the limits fit this recording?"), stacklevel=2)

    def step(self, state: TrackState, frame: int, seen: Seen, shift: np.ndarray,
             log: list | None = None) -> tuple[TrackState, int]:
        """Select, predict, measure: one step of the filter, every particle's root moved first
        by the body origin's shift. Returns the state and the evaluations spent."""
        given = self._ahead.pop(frame, None)
        key, drawn = ((given[0], {"drawn": given[1]}) if given is not None
                      else (self.frame_key(frame), {}))
        filt, info = self.filter_for(state.shape).step(key, state.filter,
                                                       self.measure(seen.obs, state.shape, log),
                                                       shift=np.r_[shift, np.zeros(NUM_DOF - 3)], **drawn)
        return state._replace(filter=filt), info.evaluations

    def draw_ahead(self, state: TrackState, frames: tuple[int, ...]) -> None:
        """Dispatch the random draws of ``frames`` now (when the filter has them, see
        :class:`~ipf_jax.filters.base.Filter`), those already dispatched kept. A cache of a pure
        function of each frame's key: the step uses it only for that frame, so the numbers are the
        ones it would have drawn.

        :meth:`track_frame` asks for the next two frames once its own is measured: the next
        frame's draws were dispatched a frame earlier and are ready when its step starts, and the
        one after computes while the device would be idle (the host checking, estimating and
        writing this frame, placing and selecting the next). Dispatched for the next frame only,
        after this one's rows, the step waited 0.6-1.0 ms a frame for them with IPF and one camera
        (docs/benchmarks.md)."""
        filt = self.filter_for(state.shape)
        if state.filter is None or filt.draws is None:
            self._ahead = {}
            return
        ahead = {f: self._ahead[f] for f in frames if f in self._ahead}
        for f in frames:
            if f not in ahead:
                key = self.frame_key(f)
                ahead[f] = (key, filt.draws(key))
        self._ahead = ahead

    def check(self, state: TrackState, frame: int, seen: Seen, status: str, info: dict,
              log: list) -> tuple[TrackState, str, float]:
        """The confidence (best weight over the median of the last frames') and the absolute loss
        test (:mod:`.loss`); a collapse of either that lasts starts a recovery, kept only if it
        weighs more; a frame still failing the loss test then is ``lost``."""
        s = self.settings
        w_best = float(state.filter.weights[best_index(state.filter.weights)])
        ref = median(state.history) if state.history else w_best
        conf = w_best / ref if ref > 0 else 0.0
        low = state.low_streak + 1 if conf < s.confidence_drop else 0
        state = state._replace(low_streak=low)
        if not s.loss_test:
            if status == "tracked" and low >= s.confidence_patience:
                state, status = self.reinitialise(state, frame, seen, w_best, info)
                conf = 1.0
            return state, status, conf
        scored = self.scorer.evaluations
        cov = self.coverage_of(self.estimate(state), seen.obs, state.shape, log)
        state = state._replace(init_evaluations=state.init_evaluations + self.scorer.evaluations - scored)
        if state.explained_levels is None:  # the first frame: clutter in a camera's silhouette
            state = state._replace(explained_levels=loss.clutter_levels(cov, self.levels).explained)
        levels = self.levels_for(state)
        bad = state.bad_streak + 1 if loss.fails(cov, levels) else 0
        due = state.next_index - state.last_attempt >= s.recovery_retry
        if status == "tracked" and (low >= s.confidence_patience or (bad >= loss.PATIENCE and due)):
            trigger = "loss test" if bad >= loss.PATIENCE else "confidence"
            state, status, log = self.recover(state, frame, seen, w_best, info, trigger)
            scored = self.scorer.evaluations
            cov = self.coverage_of(self.estimate(state), seen.obs, state.shape, log)
            state = state._replace(init_evaluations=state.init_evaluations + self.scorer.evaluations - scored)
            bad = bad if loss.fails(cov, levels) else 0
            conf = 1.0
        state = state._replace(bad_streak=bad)
        if bad == 0:
            state = state._replace(last_good=self.estimate(state))
        elif bad >= loss.PATIENCE:
            status = "lost"
        info["coverage"] = cov.to_json()
        return state, status, conf

    @staticmethod
    def estimate(state: TrackState) -> np.ndarray:
        """(D,) the estimate: the heaviest particle."""
        return state.filter.particles[best_index(state.filter.weights)]

    @property
    def recovery_search(self) -> InitSettings:
        """The global recovery's search: :data:`.recovery.GLOBAL`, or a lighter ``--init-budget``."""
        init = self.settings.init
        return GLOBAL if init == init_settings() else init

    @property
    def levels(self) -> loss.LossLevels:
        """The loss test's levels as set (``--lost-explained``, ``--lost-covered``)."""
        return loss.LossLevels(self.settings.lost_explained, self.settings.lost_covered)

    def levels_for(self, state: TrackState) -> loss.LossLevels:
        """The levels of this run: per camera once the first frame has set them."""
        levels = self.levels
        return levels if state.explained_levels is None else levels._replace(
            explained=state.explained_levels)

    def reinitialise(self, state: TrackState, frame: int, seen: Seen, w_best: float,
                     info: dict) -> tuple[TrackState, str]:
        """Without the loss test: a re-initialisation around the subject, kept if it weighs more."""
        try:
            q, w, _, n = self.initialise(frame, seen.obs, seen.masks, state.shape)
        except IPFError as e:  # a recovery attempt that cannot run keeps the track
            w, n = None, 0
            info["reinit_error"] = e.message
        self.scorer.reset_windows()  # the search's spread is not the tracked frames'
        status = "reinit-rejected"
        if w is not None and np.nanmax(w) > w_best:
            state = state._replace(filter=self.filter_for(state.shape).init(q, w))
            status = "reinit"
        state = state._replace(init_evaluations=state.init_evaluations + n, history=(),
                               low_streak=0, reinits=(*state.reinits, int(frame)))
        return state, status

    def recover(self, state: TrackState, frame: int, seen: Seen, w_best: float, info: dict,
                trigger: str) -> tuple[TrackState, str, list]:
        """A recovery attempt (:func:`.recovery.recover`), kept if it weighs more than the
        current estimate; returns the state, the frame's status and the attempt's score log."""
        t0 = time.perf_counter()
        active = [i for i in range(len(seen.masks)) if seen.obs.active[i]]
        log: list = []
        measure = self.measure(seen.obs, state.shape, log)
        still_lost = lambda q: loss.fails(self.coverage_of(q, seen.obs, state.shape, log),  # noqa: E731
                                          self.levels_for(state))
        try:
            res = recover(self.frame_key(frame, 2), [seen.masks[i] for i in active],
                          [self.cameras[i] for i in active], self.U, self.limits, state.shape,
                          measure, still_lost, state.last_good, global_settings=self.recovery_search,
                          beat=w_best)
        except IPFError as e:  # a recovery attempt that cannot run keeps the track
            res = None
            info["reinit_error"] = e.message
        self.scorer.reset_windows()  # the search's spread is not the tracked frames'
        accepted = res is not None and float(np.nanmax(res.weights)) > w_best
        n = 0 if res is None else res.evaluations
        if accepted:
            state = state._replace(filter=self.filter_for(state.shape).init(res.particles, res.weights))
        record = {"frame": int(frame), "trigger": trigger, "stage": None if res is None else res.stage,
                  "accepted": bool(accepted), "evaluations": int(n),
                  "seconds": round(time.perf_counter() - t0, 3)}
        info["recovery"] = {k: v for k, v in record.items() if k != "frame"}
        state = state._replace(init_evaluations=state.init_evaluations + n, history=(), low_streak=0,
                               reinits=(*state.reinits, int(frame)), last_attempt=state.next_index,
                               recoveries=(*state.recoveries, record))
        return state, ("reinit" if accepted else "reinit-rejected"), log

    def track_frame(self, state: TrackState, frame: int, seen: Seen,
                    ahead: tuple[int, ...] = ()) -> tuple[TrackState, FrameRecord]:
        """One frame: place, initialise or step (select, predict, measure), estimate, check.
        ``ahead``: the next frames, whose draws are dispatched once this one is measured
        (:meth:`draw_ahead`)."""
        self.scorer.new_frame()
        time_s = frame / self.fps
        info = {"frame": int(frame), "time_s": round(time_s, 6), "skipped_cameras": [
            self.dataset.cameras[i].name for i in range(len(seen.masks)) if not seen.obs.active[i]],
            "mask_quality": seen.quality}
        if not seen.person:
            self.draw_ahead(state, ahead)
            info.update(status="missing", weight=None, confidence=None, evaluations=0)
            return state, FrameRecord(frame, time_s, np.full(NUM_DOF, np.nan),
                                      np.full((NUM_POINTS, 3), np.nan), info)
        anchor, shift = self.place(state, seen)
        state = state._replace(anchor=anchor)
        log: list = []
        if state.filter is None:
            state, status, evals = self.start(state, frame, seen, log), "init", 0
        else:
            (state, evals), status = self.step(state, frame, seen, shift, log), "tracked"
        self.draw_ahead(state, ahead)  # the device is idle while the host checks, estimates, writes
        state, status, conf = self.check(state, frame, seen, status, info, log)
        best = best_index(state.filter.weights)  # the estimate: the heaviest particle
        w_best = float(state.filter.weights[best])
        state = state._replace(history=(*state.history, w_best)[-HISTORY:])
        pose = state.filter.particles[best]
        points = joint_points(pose, state.shape.values, self.U)
        if status == "init":  # one plane for the whole run (single camera, see origin)
            state = state._replace(anchor_height=float(self.U[:, 2] @ points[0]))
        info.update(status=status, weight=round(w_best, 6), confidence=round(conf, 4),
                    evaluations=int(evals), origin_shift_m=round(float(np.linalg.norm(shift)), 4))
        if status == "lost":  # written like a missing frame; the best guess stays in run.json
            info["best_guess"] = {"pose": np.round(pose, 6).tolist(),
                                  "points": np.round(points, 6).tolist()}
            pose, points = np.full(NUM_DOF, np.nan), np.full((NUM_POINTS, 3), np.nan)
        return state, FrameRecord(frame, time_s, pose, points, info)

    # -- the run -----------------------------------------------------------------------------
    def run(self, out_dir: Path, *, resume: bool = False, progress: bool = True,
            frame_hook: Callable[[FrameView], None] | None = None) -> RunResult:
        out_dir = check_writable(Path(out_dir))
        key = settings_key(self.settings, self.dataset, self.frames)
        state = self._start_state(out_dir, key, resume)
        keep = state.rows if resume else None
        joints_csv = CsvAppender(out_dir / "joints.csv", JOINT_COLUMNS, keep, lazy=True)
        poses_csv = CsvAppender(out_dir / "poses.csv", POSE_COLUMNS, keep, lazy=True)
        t_start = time.perf_counter()
        bar = tqdm(self.frames[state.next_index:], desc=f"track {self.dataset.name}", unit="frame",
                   disable=not progress, leave=True)
        frame = shape_written = None
        records = EncodedList()  # every checkpoint writes them all: each is encoded once
        saved = state.next_index
        reader = Prefetch(self.observe)  # the next frame is read while this one is tracked

        def save() -> None:  # the rows the checkpoint counts are on disk first
            nonlocal saved
            joints_csv.sync()
            poses_csv.sync()
            track_state.save(out_dir, state, key, records.update(state.records))
            write_json_atomic(out_dir / "run.json", {
                **self.run_doc(state, time.perf_counter() - t_start), "per_frame": records})
            saved = state.next_index

        def keep_done() -> None:  # on a stop: the frames since the last checkpoint, resumable too
            if state.next_index > saved:
                try:
                    save()
                except (OSError, IPFError):
                    pass  # the error to report is the one that stopped the run

        try:
            for frame in bar:
                stop.check()  # a SIGTERM whose exception was lost (in a __del__, a callback)
                t0 = time.perf_counter()
                seen = reader.take(frame)
                ahead = tuple(self.frames[state.next_index + 1:state.next_index + 3])
                if ahead:
                    reader.start(ahead[0])
                # ``state`` stays the last frame's until the rows are written
                done, rec = self.track_frame(state, frame, seen, ahead)
                joints_csv.write(frame, rec.time_s, rec.points.ravel())
                poses_csv.write(frame, rec.time_s, rec.pose)
                rec.info["seconds"] = round(time.perf_counter() - t0, 4)
                state = done._replace(next_index=state.next_index + 1, rows=state.rows + 1,
                                      records=(*state.records, rec.info))
                bar.set_postfix(w=rec.info.get("weight"), conf=rec.info.get("confidence"))
                if rec.info["status"] == "init":
                    shape_written = self.shape_doc(state)
                    write_json_atomic(out_dir / "shape.json", shape_written)
                if state.next_index % self.settings.checkpoint_every == 0 \
                        or state.next_index == len(self.frames):
                    save()
                if frame_hook is not None and rec.info["status"] != "missing":
                    guess = rec.info.get("best_guess")  # a lost frame shows its best guess
                    pose = rec.pose if guess is None else np.asarray(guess["pose"])
                    frame_hook(FrameView(frame, seen.masks, self.cameras, pose, state.shape,
                                         self.U, rec.info["weight"]))
        except IPFError as e:  # say where the run stopped and that what was computed is safe
            keep_done()
            hint = ("; rows written so far are kept: fix it and rerun with --resume"
                    if (out_dir / checkpoint.NAME).exists() else "")
            raise IPFError(f"{e.message} (at frame {frame}{hint})", e.path) from None
        except KeyboardInterrupt:  # Ctrl-C or SIGTERM (cli): resumable as well
            keep_done()
            raise
        finally:
            reader.close()
            bar.close()
            joints_csv.close()
            poses_csv.close()
        doc = self.run_doc(state, time.perf_counter() - t_start)
        shape = self.shape_doc(state)
        if shape != shape_written:  # not rewritten as it was written above
            write_json_atomic(out_dir / "shape.json", shape)
        write_json_atomic(out_dir / "run.json", {**doc, "per_frame": records.update(state.records)})
        poses = read_table(out_dir / "poses.csv", "poses file")[1][:, 2:]
        return RunResult(out_dir, self.frames, poses, read_joints_csv(out_dir / "joints.csv").points, doc)

    def _start_state(self, out_dir: Path, key: str, resume: bool) -> TrackState:
        if not resume:
            return TrackState()
        state, saved_key = track_state.load(out_dir)
        if saved_key != key:
            raise IPFError("cannot resume: the run in this folder used other settings or data", out_dir)
        checkpoint.remove_stale(out_dir)
        return state

    def shape_doc(self, state: TrackState) -> dict:
        """``shape.json``: the run's body in the shape-file format, where it came from, the fit."""
        s = self.settings
        source = (f"shape file {s.shape_file}" if s.shape_file else
                  "fitted (ipf_jax.tracking.shape_fit)" if state.shape_fit else
                  "template, proportions searched on the first frame" if s.init_pose is None
                  else "template scaled by height")
        return shape_doc(state.shape or self.base_shape, source, state.shape_fit)

    def run_doc(self, state: TrackState, seconds: float) -> dict:
        """``run.json`` (see docs/formats.md)."""
        per_frame = list(state.records)
        tracked = [r for r in per_frame if r["status"] != "missing"]
        shape = state.shape or self.base_shape
        f = self.filter
        return {
            "ipf_jax_version": __version__, "jax_version": jax.__version__,
            "device_kind": jax.devices()[0].device_kind, "host_cpu": host_cpu(),
            "dataset": str(self.dataset.path), "layout": self.dataset.layout,
            "cameras": [c.name for c in self.dataset.cameras],
            "filter": f.name, "filter_params": f.params,
            "settings": {**settings_doc(self.settings),
                         "scoring_sizes": [[c.width, c.height] for c in self.cameras]},
            "limits": limits_to_json(self.limits),
            "fps": self.fps, "up_axis": self.up_axis, "up_vector": self.U[:, 2].tolist(), "units": "m",
            "height_m": shape.height_m, "height_from_view": self.height_measured,
            "shape": shape.to_json(), "shape_file": "shape.json",
            "shape_source": self.shape_doc(state)["source"], "shape_fit": state.shape_fit,
            "shape_fit_evaluations": (state.shape_fit or {}).get("evaluations", 0),
            "frames": {"first": self.frames[0], "last": self.frames[-1], "count": len(self.frames),
                       "done": len(per_frame), "missing": sum(r["status"] == "missing" for r in per_frame),
                       "lost": sum(r["status"] == "lost" for r in per_frame)},
            "mask_quality": quality_summary([r["mask_quality"] for r in per_frame],
                                            [c.name for c in self.dataset.cameras])
            if per_frame and all("mask_quality" in r for r in per_frame) else None,
            "evaluations_per_frame": f.evaluations_per_frame,
            "chunk": self.scorer.chunk,
            "chunks_per_call": self.scorer.block,
            "threads": self.scorer.threads,
            "init_evaluations": state.init_evaluations,
            "reinitialisations": list(state.reinits),
            "recovery": recovery_summary(state.recoveries),
            "loss_levels": self.levels_for(state)._asdict() if self.settings.loss_test else None,
            "seconds": {"total": round(seconds, 3), **one_off_seconds(per_frame, state),
                        "per_tracked_frame_mean": _mean_or_none(
                            [r["seconds"] for r in tracked if r["status"] == "tracked"])},
            "per_frame": per_frame,
        }


def _mean_or_none(values: list[float]) -> float | None:
    """Their mean, rounded; None (JSON null, not NaN) for none."""
    return round(float(np.mean(values)), 4) if values else None


def one_off_seconds(per_frame: list[dict], state: TrackState) -> dict:
    """``run.json``'s one-off stages, in seconds, apart from the tracked frames: ``start`` (the
    frame(s) the run started on: automatic initialisation and shape fit, compiles included),
    ``shape_fit``, ``initialisation`` (the start without the fit) and ``recovery`` (all recovery
    attempts; without the loss test a re-initialisation's time stays in its frame's)."""
    start = sum(r.get("seconds", 0.0) for r in per_frame if r["status"] == "init")
    fit = float((state.shape_fit or {}).get("seconds", 0.0))
    return {"start": round(start, 3), "initialisation": round(max(start - fit, 0.0), 3),
            "shape_fit": round(fit, 3),
            "recovery": round(sum(r.get("seconds", 0.0) for r in state.recoveries), 3)}


def recovery_summary(recoveries: tuple[dict, ...]) -> dict:
    """``run.json``'s ``recovery``: attempts, how many were accepted, at which stage, their cost."""
    return {"attempts": len(recoveries), "accepted": sum(r["accepted"] for r in recoveries),
            "local": sum(r["accepted"] and r["stage"] == "local" for r in recoveries),
            "global": sum(r["accepted"] and r["stage"] == "global" for r in recoveries),
            "evaluations": sum(r["evaluations"] for r in recoveries),
            "per_attempt": list(recoveries)}


def track(dataset: Dataset, out_dir: str | Path, settings: TrackSettings = TrackSettings(), *,
          frames: list[int] | None = None, resume: bool = False, progress: bool = True,
          frame_hook: Callable[[FrameView], None] | None = None) -> RunResult:
    """Track ``dataset`` into ``out_dir`` (joints.csv, poses.csv, run.json). See module doc.

    frame_hook : called after every frame with a person, with the frame's :class:`FrameView`
        (e.g. :func:`ipf_jax.viz.overlay.overlay_writer` writes overlay PNGs: ``track --overlay``).
    """
    return Tracker(dataset, settings, frames).run(Path(out_dir), resume=resume, progress=progress,
                                                  frame_hook=frame_hook)
