"""Where a whole tracking frame's time goes, host and device, stage by stage.

    python benchmarks/frame_profile.py [--filter ipf] [--cameras 4] [--frames 12] [--json FILE]
                                       [-- TRACK OPTIONS]

Tracks the real ``sequenceB_2`` frames (4 calibrated cameras, real masks; ``--cameras 1`` uses
Camera1 alone) from bodytrack's initial pose, frame 0 then frame 1 alternately so the person
stays in view (a warm-up run compiles first), once under ``cProfile``. Each stage's time is the
cumulative time of the functions that do it, per tracked frame:

* ``observe``: masks read, resized, packed; blobs, rays and mask quality (``Tracker.observe``);
* ``place``: the body origin's shift from the silhouettes (``Tracker.place``);
* ``selection``: the M best distinct particles / resampling (``filters.selection``);
* ``prediction``: the rest of the filter's host step (interval grid, noise, clipping);
* ``geometry``: FK, projection and extents on the device, and the extents' transfer (``Scorer.geometry``);
* ``window plan``: ``Scorer.plan``;
* ``raster + counts``: the interval and word stages (device) and the counts' transfer;
* ``weights``: ``weights_from_counts``;
* ``estimate + check``: the heaviest particle, its host FK, confidence;
* ``files``: rows, checkpoints, run.json.

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

import ipf_jax as ipf
from ipf_jax import jax_setup, profiling
from ipf_jax.paths import shared_data_dir

#: stage -> (file suffix, function name) whose cumulative time it is
FUNCTIONS = {
    "observe": [("tracking/tracker.py", "observe")],
    "place": [("tracking/tracker.py", "place")],
    "selection": [("filters/selection.py", "top_distinct"), ("filters/selection.py", "systematic")],
    "filter step": [("filters/ipf.py", "step"), ("filters/apf.py", "step"), ("filters/sir.py", "step"),
                    ("filters/fipf.py", "step")],
    "measure": [("tracking/tracker.py", "fn")],
    "counts": [("likelihood/scorer.py", "counts")],
    "geometry": [("likelihood/scorer.py", "geometry")],
    "window plan": [("likelihood/scorer.py", "plan")],
    "weights": [("likelihood/scorer.py", "weights_from_counts")],
    "track_frame": [("tracking/tracker.py", "track_frame")],
    "host FK": [("geometry/host.py", "forward_kinematics")],
    "rows": [("data/runfiles.py", "write")],
    "checkpoint": [("tracking/state.py", "save")],
    "run.json": [("data/runfiles.py", "write_json_atomic")],
}


def cumulative(stats: pstats.Stats, keys) -> float:
    total = 0.0
    for (file, _, name), (_, _, _, ct, _) in stats.stats.items():
        if any(file.endswith(suffix) and name == fn for suffix, fn in keys):
            total += ct
    return total


def stages(stats: pstats.Stats, frames: int) -> dict:
    """Seconds per frame of each stage (see module doc) from cumulative times."""
    c = {k: cumulative(stats, v) for k, v in FUNCTIONS.items()}
    out = {
        "observe": c["observe"], "place": c["place"], "selection": c["selection"],
        "prediction": c["filter step"] - c["measure"] - c["selection"],
        "geometry": c["geometry"], "window plan": c["window plan"],
        "raster + counts": c["counts"] - c["geometry"] - c["window plan"],
        "weights": c["weights"],
        "measure (other host)": c["measure"] - c["counts"] - c["weights"],
        "estimate + check": c["track_frame"] - c["place"] - c["filter step"],
        "files": c["rows"] + c["checkpoint"] + c["run.json"],
    }
    return {k: v / frames for k, v in out.items()}


def dataset(n_cameras: int, frames: int, root: Path):
    """sequenceB_2's frames 0 and 1 alternately (``frames`` of them), ``n_cameras`` cameras."""
    data = shared_data_dir() / profiling.DATASET
    ds = ipf.open_dataset(data)
    cams = ds.cameras[:n_cameras]
    masks = np.stack([np.stack(ds.masks(f % 2)[:n_cameras]) for f in range(frames)])
    return ipf.MemoryDataset(cams, masks, fps=20.0, up_axis="+z", name="sequenceB_2")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--filter", default="ipf")
    ap.add_argument("--cameras", type=int, default=4)
    ap.add_argument("--frames", type=int, default=12)
    ap.add_argument("--budget", type=int, help="evaluations per frame (default: the filter's)")
    ap.add_argument("--resolution", type=int, default=320)
    ap.add_argument("--json", help="write the profile here")
    args = ap.parse_args(argv)
    jax_setup.configure()
    q0, height = profiling.initial_pose(shared_data_dir() / profiling.DATASET)
    settings = ipf.TrackSettings(filter=args.filter, budget=args.budget, resolution=args.resolution,
                                 init_pose=q0, height_m=height, up_axis="+z")
    ds = dataset(args.cameras, args.frames, Path(tempfile.mkdtemp()))
    with tempfile.TemporaryDirectory() as tmp:
        ipf.track(ds, Path(tmp) / "warm", settings, progress=False)  # compile
        t0 = time.perf_counter()
        plain = ipf.track(ds, Path(tmp) / "plain", settings, progress=False)
        wall = (time.perf_counter() - t0) / args.frames
        prof = cProfile.Profile()
        prof.enable()
        ipf.track(ds, Path(tmp) / "prof", settings, progress=False)
        prof.disable()
    stats = pstats.Stats(prof)
    tracked = args.frames - 1  # frame 0 is the given pose
    per = stages(stats, tracked)
    total = sum(per.values())
    doc = {"filter": args.filter, "cameras": args.cameras, "resolution": args.resolution,
           "evaluations_per_frame": plain.run["evaluations_per_frame"],
           "seconds_per_frame": plain.run["seconds"]["per_tracked_frame_mean"],
           "wall_per_frame_incl_files": round(wall, 4), "profiled_stages_s": per,
           "device": profiling.machine().get("device_kind")}
    print(f"{args.filter}, {args.cameras} camera(s), {args.resolution} px, "
          f"{doc['evaluations_per_frame']} evaluations/frame: {doc['seconds_per_frame']} s/frame "
          f"(no profiler); under cProfile:")
    for k, v in per.items():
        print(f"  {k:22s} {1000 * v:8.1f} ms  {100 * v / total:5.1f} %")
    if args.json:
        Path(args.json).write_text(json.dumps(doc, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
