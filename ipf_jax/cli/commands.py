"""Implementations of the CLI commands (argument namespaces in, files and a summary out)."""
from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

from ..body.model import DOF_NAMES
from ..errors import IPFError, require


def _frames(ds, sl: slice | None) -> list[int]:
    from ..data.frames import select_frames

    return select_frames(ds.frames, sl)


def filter_options(args) -> dict:
    opts = {}
    if getattr(args, "top_m", None) is not None:
        opts["top_m"] = args.top_m
    if getattr(args, "particles", None) is not None:
        opts["particles"] = args.particles
    if getattr(args, "points_per_dof", None) is not None:
        opts["points_per_dof"] = args.points_per_dof
    if getattr(args, "interval_width", None) is not None:
        opts["interval_width_deg"] = args.interval_width
    if getattr(args, "max_speed", None) is not None:
        opts["max_speed_deg_s"] = args.max_speed
    if getattr(args, "interesting", None):
        opts["interesting"] = tuple(s.strip() for s in args.interesting.split(",") if s.strip())
    if getattr(args, "noise_scale", None) is not None:
        opts["noise_scale"] = args.noise_scale
    if getattr(args, "layers", None) is not None:
        opts["layers"] = args.layers
    return opts


#: track/compare flags that shape the filter, named in its errors (``dest``: flag).
_FILTER_FLAGS = {"filter": "--filter", "budget": "--budget", "particles": "--particles",
                 "top_m": "--top-m", "points_per_dof": "--points-per-dof",
                 "interval_width": "--interval-width", "max_speed": "--max-speed",
                 "interesting": "--interesting", "noise_scale": "--noise-scale", "layers": "--layers"}


def check_settings(args) -> None:
    """Build the filter (and scale the body) once before any data is read: an impossible setting
    fails at once, and the error names the flags that were given (the filters' own messages name
    the parameter only)."""
    from ..body.limits import load_limits
    from ..body.shape import default_shape
    from ..filters import registry

    if args.height is not None:
        try:
            default_shape().scaled_to(args.height)
        except IPFError as e:
            raise IPFError(e.message, f"--height {args.height}") from None

    given = " ".join(f"{flag} {getattr(args, dest)}" for dest, flag in _FILTER_FLAGS.items()
                     if getattr(args, dest, None) is not None)
    limits = load_limits(args.limits)  # its errors name the limits file
    fps = args.fps if args.fps and args.fps > 0 else 20.0  # the rate is checked with the dataset
    try:
        registry.make(args.filter, filter_options(args), limits, fps, budget=args.budget)
    except IPFError as e:
        raise IPFError(e.message, given) from None


def floor_range(args) -> tuple[float, float] | None:
    """``--floor-range LO,HI`` -> TrackSettings.floor_range (None: no floor contact)."""
    return getattr(args, "floor_range", None)


def read_pose_rows(path: str | Path) -> np.ndarray:
    """(N, D) poses from a CSV with one named column per DOF (poses.csv convention)."""
    from ..data.runfiles import read_table

    path = Path(path)
    header, data = read_table(path, "poses file")
    missing = [d for d in DOF_NAMES if d not in header]
    require(not missing, f"missing DOF columns: {', '.join(missing[:5])}{'...' if len(missing) > 5 else ''}", path)
    q = data[:, [header.index(d) for d in DOF_NAMES]]
    require(bool(np.all(np.isfinite(q))), "poses contain NaN or non-numeric values", path)
    require(bool(np.all(np.abs(q) <= 1e4)), "poses hold values beyond 1e4 (metres or radians)", path)
    return q


def _init_pose(args, ds):
    """(q, height) from --init-pose: a poses CSV (first row) or a bodytrack InitialPose.txt."""
    path = Path(args.init_pose)
    if path.suffix.lower() == ".txt":
        from ..analysis.bodytrack import fit_our_pose, read_body_shape, read_pose
        from ..analysis.bodytrack.kinematics import bodytrack_points

        shape_file = path.parent / "BodyShapeParameters.txt"
        require(shape_file.exists(), "a bodytrack pose needs BodyShapeParameters.txt beside it", path)
        pose = read_pose(path)[0]
        fit = fit_our_pose(bodytrack_points(pose, read_body_shape(shape_file)), up=args.up or "+z",
                           height_m=args.height)
        return fit.q, fit.height_m
    return read_pose_rows(path)[0], args.height


#: ``track --init-budget``: the full search, or a ~10x cheaper one (one height when given,
#: 8 headings, one refinement round) for quick looks and end-to-end tests.
INIT_BUDGETS = {
    "default": None,
    "small": dict(headings=8, position_steps=0, modes=1, keep=8, refine_rounds=1,
                  refine_particles=64, pattern_keep=2, pattern_sweeps=1),
}


def init_settings(args):
    """``--init-budget`` -> :class:`ipf_jax.tracking.initialise.InitSettings`."""
    from ..tracking.initialise import InitSettings

    return InitSettings(**(INIT_BUDGETS[getattr(args, "init_budget", "default")] or {}))


def track(args) -> int:
    from ..data.dataset import open_dataset
    from ..tracking.tracker import DEFAULT_RESOLUTION, TrackSettings
    from ..tracking.tracker import track as run_track

    check_settings(args)
    ds = open_dataset(args.dataset)
    frames = _frames(ds, args.frames)
    init_pose, height = (None, args.height) if not args.init_pose else _init_pose(args, ds)
    require(args.chunk >= 1, f"--chunk must be >= 1 (got {args.chunk})")
    require(args.checkpoint_every >= 1, f"--checkpoint-every must be >= 1 (got {args.checkpoint_every})")
    settings = TrackSettings(
        filter=args.filter, filter_options=filter_options(args), budget=args.budget,
        resolution=args.resolution or DEFAULT_RESOLUTION, fps=args.fps, height_m=height,
        shape_file=args.shape, limits=args.limits, up_axis=args.up, seed=args.seed, chunk=args.chunk,
        kernel=args.kernel, checkpoint_every=args.checkpoint_every, init_pose=init_pose,
        floor_range=floor_range(args),
        init=init_settings(args))
    res = run_track(ds, args.out, settings, frames=frames, resume=args.resume,
                    progress=not args.quiet, overlay=args.overlay)
    run = res.run
    print(f"tracked {run['frames']['done']} frames ({run['frames']['missing']} missing) of {ds.name} "
          f"with {run['filter']} ({run['evaluations_per_frame']} evaluations/frame), "
          f"{run['seconds']['per_tracked_frame_mean']} s/frame; up axis {run['up_axis']}, "
          f"height {run['height_m']:.2f} m; re-initialised at {run['reinitialisations'] or 'no frame'}")
    print(f"wrote {Path(args.out) / 'joints.csv'}, poses.csv, run.json")
    return 0


def score(args) -> int:
    from ..body.shape import default_shape, load_shape
    from ..data.dataset import open_dataset
    from ..data.silhouette import resize_mask
    from ..geometry.world import detect_up_axis, up_rotation
    from ..likelihood.scorer import Scorer, make_observation, weights_from_counts
    from ..reference import likelihood as ref
    from ..tracking.tracker import DEFAULT_RESOLUTION, _scoring_cameras

    ds = open_dataset(args.dataset)
    require(args.frame in ds.frames, f"frame {args.frame} is not in the dataset "
            f"({min(ds.frames)}..{max(ds.frames)})", ds.path)
    poses = read_pose_rows(args.poses)
    shape = load_shape(args.shape) if args.shape else default_shape()
    if args.height:
        shape = shape.scaled_to(args.height)
    masks = ds.masks(args.frame)
    up = args.up or ds.up_axis or detect_up_axis(ds.cameras, masks)
    U = up_rotation(up)
    cams, scales = _scoring_cameras(ds.cameras, args.resolution or DEFAULT_RESOLUTION)
    small = [m if s == 1.0 else resize_mask(m, c.height, c.width) for m, s, c in zip(masks, scales, cams)]
    obs = make_observation(small)
    out = {"dataset": str(ds.path), "frame": args.frame, "up_axis": up,
           "scoring_sizes": [[c.width, c.height] for c in cams], "cameras": [c.name for c in ds.cameras],
           "height_m": shape.height_m, "skipped_cameras": [c.name for c, a in zip(ds.cameras, obs.active) if not a]}
    results = {}
    backends = ["jax", "numpy"] if args.backend == "both" else [args.backend]
    for backend in backends:
        t0 = time.perf_counter()
        if backend == "jax":
            scorer = Scorer(cams, shape, U)
            scorer.counts(poses, obs)  # compile outside the timing
            t0 = time.perf_counter()
            counts = scorer.counts(poses, obs)
        else:
            counts = ref.counts(poses, shape.values, U, cams, small)
        seconds = time.perf_counter() - t0
        w, w_cam = weights_from_counts(counts, obs.active)
        results[backend] = counts
        out[backend] = {
            "seconds": round(seconds, 6), "particles_per_s": round(len(poses) / max(seconds, 1e-9), 1),
            "poses": [{"row": i, "w": None if np.isnan(w[i]) else float(w[i]),
                       "cameras": [{"name": c.name, "nc": int(counts[i, k, 0]), "ns": int(counts[i, k, 1]),
                                    "nm": int(counts[i, k, 2]),
                                    "w": None if np.isnan(w_cam[i, k]) else float(w_cam[i, k])}
                                   for k, c in enumerate(ds.cameras)]} for i in range(len(poses))]}
    if len(results) == 2:
        diff = np.abs(results["jax"] - results["numpy"])
        out["agreement"] = {"max_abs_count_difference": int(diff.max()),
                            "identical_fraction": float(np.mean(np.all(diff == 0, axis=-1))),
                            "note": "geometry is float32 (JAX) vs float64 (NumPy); the raster stage "
                                    "is exact, so differences come only from boundary pixels"}
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps(out, indent=1))
    for backend in backends:
        ws = [p["w"] for p in out[backend]["poses"]]
        print(f"{backend}: {len(poses)} poses, {out[backend]['particles_per_s']} poses/s, "
              f"w = {', '.join(f'{x:.4f}' if x is not None else 'nan' for x in ws[:6])}"
              f"{' ...' if len(ws) > 6 else ''}")
    if "agreement" in out:
        print(f"JAX vs NumPy: max count difference {out['agreement']['max_abs_count_difference']} px")
    print(f"wrote {args.out}")
    return 0


def demo(args) -> int:
    from .demo import run_demo

    return run_demo(Path(args.out), n_frames=args.num_frames, n_cameras=args.cameras, top_m=args.top_m,
                    seed=args.seed, init=init_settings(args))
