"""Where a whole tracking frame's time goes, host and device, stage by stage.

    python benchmarks/frame_profile.py [--filter ipf] [--cameras 4] [--frames 12] [--json FILE]
                                       [--data FOLDER]

Tracks the real ``sequenceB_2`` frames (4 calibrated cameras, real masks; ``--cameras 1`` uses
Camera1 alone) from bodytrack's initial pose, frame 0 then frame 1 alternately so the person
stays in view (a warm-up run compiles first), once under ``cProfile``. ``--data FOLDER`` tracks
that data set's first ``--frames`` frames instead (e.g. a ``mocap_walk_render`` set): the warm-up
run initialises automatically and the timed runs start from its first pose, so the profile is of
tracked frames, not of the initialisation. Each stage's time is the cumulative time of the
functions that do it, per tracked frame:

* ``observe``: masks read, resized, packed; blobs, rays and mask quality (``Tracker.observe``);
* ``place``: the body origin's shift from the silhouettes (``Tracker.place``);
* ``selection``: the M best distinct particles / resampling (``filters.selection``);
* ``posture``: the factored filter's posture children (the pelvis moved, the legs' angles
  solved so the feet stay: ``filters/posture.py``);
* ``prediction``: the rest of the filter's host step (interval grid, noise, clipping);
* ``geometry``: FK, projection and extents on the device, and the extents' transfer (``Scorer.geometry``);
* ``window plan``: ``Scorer.plan``;
* ``raster + counts``: the interval and word stages (device) and the counts' transfer;
* ``weights``: ``weights_from_counts``;
* ``priors``: the tracker's priors on the weights (``tracking/prior.py``: with one camera the lean
  prior, on by default; ``--lean-prior 0`` turns it off to compare);
* ``files``: rows, checkpoints, run.json;
* ``other host``: the rest of ``Tracker.run`` per tracked frame (estimate, its host FK, confidence,
  records, the bookkeeping of the loop).

``measure step`` is the device part (geometry + window plan + raster + counts + weights) and
``frame / measure`` the whole frame over it, both under the profiler.

The issue's 1.25x target is read without the profiler (cProfile slows Python-heavy host stages
more than the device's): the same run once more, unprofiled, with the time spent inside the
filter's measure calls taken per step (:func:`ipf_jax.analysis.compare.recording`), gives
``frame_over_measure_unprofiled`` (the tracked frames' own seconds in ``run.json`` over the time
in their measure calls) and ``run_over_measure_unprofiled`` (the whole run, its start, checkpoints
and final files included, over the same).

The stages are found by file and function name in both package layouts (today's stage packages and
the flat one of older revisions), so ``PYTHONPATH=OLD_TREE python benchmarks/frame_profile.py``
profiles an older revision with the same table.

Under the profiler Python-heavy stages look slower than they are; ``seconds_per_frame`` (run.json,
no profiler, same run settings) is the reference. The device stages include the host's wait for
them (JAX dispatches asynchronously).
"""
from __future__ import annotations

import argparse
import cProfile
import json
import pstats
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

#: stage -> [(file suffix, function name, caller names or None)] whose cumulative time it is;
#: suffixes match both layouts (``ipf_jax/tracking/tracker.py`` and ``ipf_jax/tracker.py``)
FUNCTIONS = {
    "observe": [("/tracker.py", "observe", None), ("/origin.py", "silhouette_rays", ("run",))],
    "place": [("/origin.py", "observe_anchor", None), ("/origin.py", "root_shift", None)],
    "selection": [("filters/selection.py", "top_distinct", ("step",)),
                  ("filters/selection.py", "systematic", ("resample_diffuse", "step")),
                  ("filters/selection.py", "systematic_at", ("resample_diffuse",))],
    "posture": [("filters/posture.py", "children", None)],
    "filter step": [("filters/ipf.py", "step", None), ("filters/apf.py", "step", None),
                    ("filters/sir.py", "step", None), ("filters/fipf.py", "step", None)],
    "measure": [("/tracker.py", "fn", None)],
    "counts": [("likelihood/scorer.py", "counts", None), ("ipf_jax/likelihood.py", "counts", None)],
    "geometry": [("likelihood/scorer.py", "geometry", None),
                 ("ipf_jax/likelihood.py", "geometry", None)],
    "window plan": [("likelihood/scorer.py", "plan", None), ("ipf_jax/likelihood.py", "plan", None)],
    "weights": [("likelihood/scorer.py", "weights_from_counts", None),
                ("ipf_jax/likelihood.py", "weights_from_counts", None)],
    "priors": [("tracking/prior.py", "level_pelvis", None),
               ("tracking/prior.py", "upright_to_camera", None)],
    "rows": [("data/runfiles.py", "write", None), ("ipf_jax/outputs.py", "write", None)],
    "checkpoint": [("tracking/state.py", "save", None), ("ipf_jax/checkpoint.py", "save", ("run",))],
    "run.json": [("data/runfiles.py", "write_json_atomic", None),
                 ("ipf_jax/outputs.py", "write_json_atomic", None)],
    "run": [("/tracker.py", "run", None)],
}


def cumulative(stats: pstats.Stats, keys) -> float:
    """Summed cumulative seconds of the functions ``keys`` (only the calls from the given callers
    when a caller tuple is given)."""
    total = 0.0
    for (file, _, name), (_, _, _, ct, callers) in stats.stats.items():
        for suffix, fn, by in keys:
            if not (file.endswith(suffix) and name == fn):
                continue
            if by is None:
                total += ct
            else:
                total += sum(v[3] for (_, _, caller), v in callers.items() if caller in by)
    return total


def stages(stats: pstats.Stats, frames: int) -> dict:
    """Seconds per frame of each stage (see module doc) from cumulative times."""
    c = {k: cumulative(stats, v) for k, v in FUNCTIONS.items()}
    out = {
        "observe": c["observe"], "place": c["place"], "selection": c["selection"],
        "posture": c["posture"],
        "prediction": c["filter step"] - c["measure"] - c["selection"] - c["posture"],
        "geometry": c["geometry"], "window plan": c["window plan"],
        "raster + counts": c["counts"] - c["geometry"] - c["window plan"],
        "weights": c["weights"], "priors": c["priors"],
        "measure (other host)": c["measure"] - c["counts"] - c["weights"] - c["priors"],
        "files": c["rows"] + c["checkpoint"] + c["run.json"],
    }
    out["other host"] = c["run"] - sum(out.values())
    return {k: v / frames for k, v in out.items()}


def api():
    """(track, TrackSettings, open_dataset, MemoryDataset, profiling) of whichever layout is on
    the path."""
    try:
        from ipf_jax import profiling
        from ipf_jax.data.dataset import MemoryDataset, open_dataset
        from ipf_jax.tracking.passes import track
        from ipf_jax.tracking.tracker import TrackSettings
    except ImportError:  # the flat layout of older revisions
        from ipf_jax import bench as profiling
        from ipf_jax.dataset import MemoryDataset, open_dataset
        from ipf_jax.tracker import TrackSettings, track
    return track, TrackSettings, open_dataset, MemoryDataset, profiling


def alternating(open_dataset, MemoryDataset, data: Path, n_cameras: int, frames: int):
    """The data set's frames 0 and 1 alternately (``frames`` of them), ``n_cameras`` cameras."""
    ds = open_dataset(data)
    cams = ds.cameras[:n_cameras]
    masks = np.stack([np.stack(ds.masks(f % 2)[:n_cameras]) for f in range(frames)])
    return MemoryDataset(cams, masks, fps=20.0, up_axis="+z", name=data.name)


def first_frames(open_dataset, MemoryDataset, data: Path, n_cameras: int, frames: int):
    """The data set's first ``frames`` frames, ``n_cameras`` cameras, its own rate and up axis."""
    ds = open_dataset(data)
    masks = np.stack([np.stack(ds.masks(f)[:n_cameras]) for f in ds.frames[:frames]])
    return MemoryDataset(ds.cameras[:n_cameras], masks, fps=ds.fps, up_axis=ds.up_axis,
                         name=data.name)


def measured_run(ds, settings, out_dir: Path) -> dict:
    """One unprofiled run with the time inside the filter's measure calls taken per step: the
    tracked frames' seconds and the whole run's over it. Empty for layouts without the hook."""
    try:
        from ipf_jax.analysis.compare import recording
        from ipf_jax.tracking.tracker import Tracker
    except ImportError:
        return {}
    tracker, log = Tracker(ds, settings), []
    tracker.filter_hook = lambda f: recording(f, tracker.scorer, log)
    t0 = time.perf_counter()
    result = tracker.run(out_dir, progress=False)
    wall = time.perf_counter() - t0
    inside = sum(s.likelihood_seconds for s in log)
    frames = sum(r["seconds"] for r in result.run["per_frame"] if r["status"] == "tracked")
    return {"measure_seconds_unprofiled": round(inside, 4),
            "frame_over_measure_unprofiled": round(frames / inside, 3),
            "run_over_measure_unprofiled": round(wall / inside, 3)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--filter", default="ipf")
    ap.add_argument("--cameras", type=int, default=4)
    ap.add_argument("--frames", type=int, default=12)
    ap.add_argument("--budget", type=int, help="evaluations per frame (default: the filter's)")
    ap.add_argument("--resolution", type=int, default=320)
    ap.add_argument("--lean-prior", type=float, help="sigma (deg) of the one-camera lean prior "
                    "(default: the tracker's; 0: off; revisions without it: leave unset)")
    ap.add_argument("--data", help="track this data set's first frames (default: sequenceB_2 0,1,0,...)")
    ap.add_argument("--json", help="write the profile here")
    ap.add_argument("--top", type=int, default=0, help="also print the N functions of most own time")
    args = ap.parse_args(argv)
    from ipf_jax import jax_setup
    from ipf_jax.paths import shared_data_dir

    jax_setup.configure()
    track, TrackSettings, open_dataset, MemoryDataset, profiling = api()
    common = dict(filter=args.filter, budget=args.budget, resolution=args.resolution)
    if args.lean_prior is not None:
        common["lean_prior_deg"] = args.lean_prior
    tmp = tempfile.TemporaryDirectory()
    if args.data is None:
        q0, height = profiling.initial_pose(shared_data_dir() / profiling.DATASET)
        settings = TrackSettings(**common, init_pose=q0, height_m=height, up_axis="+z")
        ds = alternating(open_dataset, MemoryDataset, shared_data_dir() / profiling.DATASET,
                         args.cameras, args.frames)
        track(ds, Path(tmp.name) / "warm", settings, progress=False)  # compile
    else:
        ds = first_frames(open_dataset, MemoryDataset, Path(args.data), args.cameras, args.frames)
        warm = track(ds, Path(tmp.name) / "warm", TrackSettings(**common), progress=False)
        height = warm.run["height_m"]
        settings = TrackSettings(**common, init_pose=warm.poses[0], height_m=height)
        track(ds, Path(tmp.name) / "warm2", settings, progress=False)  # compile the tracked path
    t0 = time.perf_counter()
    plain = track(ds, Path(tmp.name) / "plain", settings, progress=False)
    wall = (time.perf_counter() - t0) / args.frames
    unprofiled = measured_run(ds, settings, Path(tmp.name) / "timed")
    prof = cProfile.Profile()
    prof.enable()
    track(ds, Path(tmp.name) / "prof", settings, progress=False)
    prof.disable()
    tmp.cleanup()
    per = stages(pstats.Stats(prof), args.frames - 1)  # frame 0 is the given pose
    total = sum(per.values())
    measure = sum(per[k] for k in ("geometry", "window plan", "raster + counts", "weights"))
    doc = {"filter": args.filter, "cameras": args.cameras, "resolution": args.resolution,
           "lean_prior_deg": getattr(settings, "lean_prior_deg", None),
           "data": ds.name, "evaluations_per_frame": plain.run["evaluations_per_frame"],
           "seconds_per_frame": plain.run["seconds"]["per_tracked_frame_mean"],
           "wall_per_frame_incl_files": round(wall, 4), "profiled_stages_s": per,
           "frame_over_measure": round(total / measure, 3), **unprofiled,
           "device": profiling.machine().get("device_kind")}
    print(f"{ds.name}, {args.filter}, {args.cameras} camera(s), {args.resolution} px, "
          f"{doc['evaluations_per_frame']} evaluations/frame: {doc['seconds_per_frame']} s/frame "
          f"(no profiler); under cProfile:")
    for k, v in per.items():
        print(f"  {k:22s} {1000 * v:8.1f} ms  {100 * v / total:5.1f} %")
    print(f"  {'frame total':22s} {1000 * total:8.1f} ms; measure step {1000 * measure:.1f} ms; "
          f"frame / measure {total / measure:.2f}")
    if unprofiled:
        print(f"  without the profiler: frame / measure "
              f"{unprofiled['frame_over_measure_unprofiled']:.3f}, whole run / measure "
              f"{unprofiled['run_over_measure_unprofiled']:.3f} (target <= 1.25)")
    if args.top:
        pstats.Stats(prof).sort_stats("tottime").print_stats(args.top)
    if args.json:
        Path(args.json).write_text(json.dumps(doc, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
