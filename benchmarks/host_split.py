"""Where a tracked frame's host time goes, without a profiler: wall time inside named functions.

    python benchmarks/host_split.py [--filter ipf] [--cameras 1] [--frames 80] [--json FILE]

``frame_profile.py`` splits a frame under ``cProfile``, which costs about a microsecond per Python
call and so inflates the host's many small steps (a tracked IPF frame makes ~3,000 calls). Here
the same run (``sequenceB_2``'s frames 0 and 1 alternately from bodytrack's initial pose, a
warm-up run first) is timed with plain ``perf_counter`` wrappers around a few named functions
only, each called a handful of times a frame, so the host's steps are read at their own speed.
Nested functions are counted in each one that contains them (``step`` holds ``counts``, which holds
``geometry``), so the rows do not add up; ``measure`` is ``counts`` + ``weights`` + ``priors``, and
``host`` the tracked frame's seconds (``run.json``) less it.
"""
from __future__ import annotations

import argparse
import collections
import functools
import json
import sys
import tempfile
import time
from pathlib import Path

import frame_profile as fp

#: (module, attribute path, label) of the functions timed
TIMED = [
    ("ipf_jax.tracking.tracker", "Tracker.track_frame", "track_frame"),
    ("ipf_jax.tracking.tracker", "Tracker.step", "step (select, predict, measure)"),
    ("ipf_jax.tracking.tracker", "Tracker.place", "place"),
    ("ipf_jax.tracking.tracker", "Tracker.check", "check (confidence, loss test)"),
    ("ipf_jax.tracking.tracker", "Tracker.draw_ahead", "draw ahead (dispatch)"),
    ("ipf_jax.tracking.tracker", "joint_points", "estimate's points (host FK)"),
    ("ipf_jax.tracking.tracker", "upright_to_camera", "priors"),
    ("ipf_jax.tracking.tracker", "weights_from_counts", "weights"),
    ("ipf_jax.tracking.tracker", "CsvAppender.write", "rows"),
    ("ipf_jax.likelihood.scorer", "Scorer.counts", "counts"),
    ("ipf_jax.likelihood.scorer", "Scorer.geometry", "geometry"),
    ("ipf_jax.likelihood.scorer", "Scorer.plan", "window plan"),
    ("ipf_jax.filters.ipf", "top_distinct", "selection (IPF)"),
    ("ipf_jax.filters.fipf", "top_distinct", "selection (fipf)"),
    ("ipf_jax.filters.apf", "resample_diffuse", "resample and diffuse (APF)"),
    ("ipf_jax.filters.apf", "annealed_weights", "annealing (APF)"),
    ("ipf_jax.body.limits", "Limits.clip", "clip"),
]


def timed(acc: dict, label: str, f):
    @functools.wraps(f)
    def g(*args, **kwargs):
        t = time.perf_counter()
        try:
            return f(*args, **kwargs)
        finally:
            acc[label] += time.perf_counter() - t
    return g


def install(acc: dict) -> None:
    """Wrap every function of :data:`TIMED` (the class attribute, or the module's name for it)."""
    import importlib

    for module, path, label in TIMED:
        owner = importlib.import_module(module)
        *outer, name = path.split(".")
        for part in outer:
            owner = getattr(owner, part)
        setattr(owner, name, timed(acc, label, getattr(owner, name)))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--filter", default="ipf")
    ap.add_argument("--cameras", type=int, default=1)
    ap.add_argument("--frames", type=int, default=80)
    ap.add_argument("--json", help="write the split here")
    args = ap.parse_args(argv)
    from ipf_jax import jax_setup
    from ipf_jax.paths import shared_data_dir

    jax_setup.configure()
    track, TrackSettings, open_dataset, MemoryDataset, profiling = fp.api()
    q0, height = profiling.initial_pose(shared_data_dir() / profiling.DATASET)
    settings = TrackSettings(filter=args.filter, init_pose=q0, height_m=height, up_axis="+z")
    ds = fp.alternating(open_dataset, MemoryDataset, shared_data_dir() / profiling.DATASET,
                        args.cameras, args.frames)
    with tempfile.TemporaryDirectory() as tmp:
        track(ds, Path(tmp) / "warm", settings, progress=False)  # compile
        acc: dict = collections.defaultdict(float)
        install(acc)
        run = track(ds, Path(tmp) / "run", settings, progress=False).run
    tracked = [r["seconds"] for r in run["per_frame"] if r["status"] == "tracked"]
    per = {k: 1e3 * v / args.frames for k, v in sorted(acc.items(), key=lambda kv: -kv[1])}
    frame = 1e3 * sum(tracked) / len(tracked)
    measure = sum(per.get(k, 0.0) for k in ("counts", "weights", "priors"))
    doc = {"filter": args.filter, "cameras": args.cameras, "frames": args.frames,
           "frame_ms": round(frame, 3), "measure_ms": round(measure, 3),
           "host_ms": round(frame - measure, 3), "frame_over_measure": round(frame / measure, 3),
           "functions_ms_per_frame": {k: round(v, 3) for k, v in per.items()},
           "device": profiling.machine().get("device_kind")}
    print(f"{args.filter}, {args.cameras} camera(s), {len(tracked)} tracked frames: frame {frame:.2f} ms, "
          f"measure {measure:.2f} ms, host {frame - measure:.2f} ms (frame / measure {frame / measure:.3f}); "
          "ms per frame inside:")
    for k, v in per.items():
        print(f"  {k:32s} {v:7.3f}")
    if args.json:
        Path(args.json).write_text(json.dumps(doc, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
