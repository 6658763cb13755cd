"""A tracker's measure calls with its chunks in blocks (one program per block) against one chunk
per compiled call, replayed on the same particles.

    python benchmarks/blocks.py [--filter ipf] [--cameras 1] [--frames 40] [--calls 12]
                                [--rounds 7] [--json FILE]

Tracks the real ``sequenceB_2`` frames (frames 0 and 1 alternately, bodytrack's initial pose, as
``frame_profile.py`` does) and records every measure call's particles and masks. Its last
``--calls`` calls are then scored again by the tracker's own scorer, with its chunking
(:func:`ipf_jax.likelihood.scorer.pick_chunking`: e.g. IPF's 16 chunks of 416 in one call) and
with the same chunks one per compiled call, the two taking turns round by round (so a drift of
the machine's speed hits both alike). The counts must be equal (exit 1 otherwise). Prints and
writes the median milliseconds per call of each and the ratio per round.
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from frame_profile import alternating, api

from ipf_jax import jax_setup
from ipf_jax.paths import shared_data_dir
from ipf_jax.profiling import device_line, machine
from ipf_jax.tracking.tracker import Tracker


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--filter", default="ipf")
    ap.add_argument("--cameras", type=int, default=1)
    ap.add_argument("--frames", type=int, default=40)
    ap.add_argument("--calls", type=int, default=12, help="the run's last calls replayed")
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--json", type=Path)
    args = ap.parse_args(argv)
    jax_setup.configure()
    print(device_line())
    _, TrackSettings, open_dataset, MemoryDataset, profiling = api()
    data = shared_data_dir() / profiling.DATASET
    q0, height = profiling.initial_pose(data)
    settings = TrackSettings(filter=args.filter, init_pose=q0, height_m=height, up_axis="+z")
    tracker = Tracker(alternating(open_dataset, MemoryDataset, data, args.cameras, args.frames),
                      settings)
    calls = []
    measure = tracker.measure

    def recording(obs, shape=None, log=None, pad=False):
        fn = measure(obs, shape, log, pad)

        def score(particles, *rest):
            calls.append((particles.copy(), obs))
            return fn(particles, *rest)
        return score

    tracker.measure = recording
    with tempfile.TemporaryDirectory() as out:
        tracker.run(Path(out), progress=False)
    scorer = tracker.scorer
    block = scorer.block
    replay = [c for c in calls if len(c[0]) > scorer.chunk][-args.calls:]

    def blocked(particles, obs):
        scorer.block = block
        return scorer.counts(particles, obs)

    def single(particles, obs):
        scorer.block = 1
        return scorer.counts(particles, obs)

    ways = {"blocks": blocked, "one chunk per call": single}
    for particles, obs in replay:  # compiles both, checks the counts
        if not np.array_equal(blocked(particles, obs), single(particles, obs)):
            sys.exit("blocks.py: the counts differ between the two ways")
    ms = {k: [] for k in ways}
    for _ in range(args.rounds):
        for k, fn in ways.items():
            t0 = time.perf_counter()
            for particles, obs in replay:
                fn(particles, obs)
            ms[k].append((time.perf_counter() - t0) / len(replay) * 1e3)
    scorer.block = block
    ratios = [a / b for a, b in zip(ms["one chunk per call"], ms["blocks"])]
    doc = {"filter": args.filter, "cameras": args.cameras, "frames": args.frames,
           "calls": len(replay), "particles": sorted({len(p) for p, _ in replay}),
           "chunk": scorer.chunk, "chunks_per_call": block, "rounds": args.rounds,
           "median_ms": {k: round(float(np.median(v)), 2) for k, v in ms.items()},
           "ratio_per_round": [round(r, 3) for r in ratios], "machine": machine()}
    print(f"{args.filter}, {args.cameras} camera(s): {len(replay)} calls of {doc['particles']} "
          f"particles, chunks of {scorer.chunk}, {block} per call")
    for k, v in doc["median_ms"].items():
        print(f"  {k:20s} {v:8.2f} ms per call (median of {args.rounds} rounds)")
    print(f"  one chunk per call / blocks, per round: {doc['ratio_per_round']}")
    if args.json:
        args.json.write_text(json.dumps(doc, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
