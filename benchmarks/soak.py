"""Soak: a long self-rendered run must not grow in memory after warm-up.

SELF-RENDERED (the tracker's own capsule model draws the masks): this checks the machinery over
a long run (compiled-shape buckets, CSV appends, checkpoints, the host loop), not accuracy.

    python benchmarks/soak.py --frames 1000 --json benchmarks/results/soak.json

Tracks a procedural walk (a person on a treadmill seen by 3 cameras at 160x120,
IPF with a small M so the run takes minutes) and samples the process's resident set size (VmRSS)
from a thread every 0.5 s. Reports RSS at the end of warm-up (default: after 10% of the frames),
at the end, the largest value after warm-up, and the least-squares slope of RSS after warm-up
in MB per 1000 frames. The run fails (exit 1) when the growth after warm-up exceeds --max-growth-mb.
"""
from __future__ import annotations

import argparse
import json
import platform
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np


def rss_mb() -> float:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024.0
    return float("nan")


def treadmill(n_frames: int, fps: float, shape) -> np.ndarray:
    """Walking on a treadmill (speed 0: the legs and arms swing, the pelvis stays above one floor
    point), so any number of frames stays in view."""
    from ipf_jax.viz import synthetic as syn

    return syn.procedural_walk(n_frames, fps, shape=shape, speed=0.0, heading_deg=30.0,
                               start=(0.6, 0.0))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--frames", type=int, default=1000)
    ap.add_argument("--top-m", type=int, default=8, help="IPF M (I = 81): 648 particles per frame")
    ap.add_argument("--warmup", type=float, default=0.1, help="fraction of frames counted as warm-up")
    ap.add_argument("--checkpoint-every", type=int, default=50)
    ap.add_argument("--max-growth-mb", type=float, default=50.0)
    ap.add_argument("--json", help="write the record here")
    args = ap.parse_args(argv)

    from ipf_jax import jax_setup

    jax_setup.configure()
    from ipf_jax.body.shape import default_shape
    from ipf_jax.data.dataset import MemoryDataset
    from ipf_jax.tracking.tracker import TrackSettings, track
    from ipf_jax.viz import synthetic as syn

    fps, n = 20.0, args.frames
    shape = default_shape(1.72)
    cams = syn.ring_cameras(3, width=160, height=120, focal_px=190.0, radius=4.0)
    q = treadmill(n, fps, shape)
    t0 = time.perf_counter()
    masks = syn.render_masks(q, shape, cams)  # (T, C, H, W) bool
    render_s = time.perf_counter() - t0
    ds = MemoryDataset(cams, masks, fps=fps, up_axis="+z")
    settings = TrackSettings(filter_options={"top_m": args.top_m}, init_pose=q[0], height_m=1.72,
                             fps=fps, checkpoint_every=args.checkpoint_every, resolution=160)

    samples: list[tuple[float, float]] = []
    stop = threading.Event()

    def sample():
        while not stop.is_set():
            samples.append((time.perf_counter(), rss_mb()))
            stop.wait(0.5)

    sampler = threading.Thread(target=sample, daemon=True)
    start_rss = rss_mb()
    with tempfile.TemporaryDirectory() as tmp:
        sampler.start()
        t0 = time.perf_counter()
        res = track(ds, Path(tmp) / "run", settings, progress=True)
        wall = time.perf_counter() - t0
        stop.set()
        sampler.join()
        run = res.run

    # frame times from the run: map each RSS sample onto the frame being tracked then
    per_frame = [r for r in run["per_frame"] if r.get("seconds") is not None]
    # per-frame seconds leave out the bookkeeping between frames (checkpoints, run.json):
    # stretch them over the whole wall time so each sample maps to the frame then running
    secs = np.cumsum([r["seconds"] for r in per_frame])
    ends = t0 + secs * (wall / secs[-1])
    ts = np.array([s[0] for s in samples])
    rss = np.array([s[1] for s in samples])
    frame_at = np.searchsorted(ends, ts)  # index of the frame in progress
    warm = frame_at >= int(args.warmup * len(per_frame))
    warm &= frame_at < len(per_frame)
    if warm.sum() < 3:
        print("error: too few RSS samples after warm-up; run more frames", file=sys.stderr)
        return 2
    slope = float(np.polyfit(frame_at[warm], rss[warm], 1)[0]) * 1000.0
    warm_rss = float(rss[warm][0])
    growth = float(rss[warm].max() - warm_rss)
    missing = sum(1 for r in run["per_frame"] if r["status"] == "missing")
    record = {
        "task": "soak", "self_rendered": True, "frames": n, "cameras": len(cams),
        "height": 120, "width": 160, "particles": run["evaluations_per_frame"],
        "wall_s": round(wall, 1), "render_s": round(render_s, 1),
        "seconds_per_frame": round(wall / n, 4),
        "rss_start_mb": round(start_rss, 1), "rss_after_warmup_mb": round(warm_rss, 1),
        "rss_end_mb": round(float(rss[warm][-1]), 1), "rss_max_after_warmup_mb": round(float(rss[warm].max()), 1),
        "growth_after_warmup_mb": round(growth, 1), "slope_mb_per_1000_frames": round(slope, 2),
        "rss_samples": int(warm.sum()), "missing_frames": missing, "reinitialisations": sum(1 for r in run["per_frame"] if r["status"] == "reinit"),
        "machine": f"{platform.machine()} {platform.processor() or ''}".strip(),
    }
    print(json.dumps(record, indent=1))
    if args.json:
        Path(args.json).parent.mkdir(parents=True, exist_ok=True)
        Path(args.json).write_text(json.dumps([record], indent=1) + "\n")
    if growth > args.max_growth_mb:
        print(f"error: RSS grew {growth:.1f} MB after warm-up (limit {args.max_growth_mb} MB)", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
