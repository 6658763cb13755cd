"""Time one frame's measure calls at several scorer chunk sizes, against the chunk cost model.

    python benchmarks/chunk_sizes.py --json FILE [--filter fipf] [--chunks 128,216,256,512]
                                     [--cameras 4] [--width 320] [--repeats 7]

A filter's frame is a fixed sequence of measure calls (``Filter.calls``: IPF one of 6561, the
factored filter 14 of 1017 / 648 / 216 / 72 particles). The scorer evaluates each call in chunks of
a fixed compiled size, the last one padded, and a given number of chunks per compiled call
(:func:`~ipf_jax.likelihood.scorer.pick_chunking` chooses it for each chunk size), so the chunk
size decides how many particles are really rasterised and how many compiled calls are dispatched. On the bench scene
(:func:`ipf_jax.profiling.load_scene`: PARSEC ``sequenceB_2`` frame 0, its real cameras and masks,
poses around bodytrack's initial pose), each chunk size's scorer runs the filter's whole call
sequence, the sizes taking turns repeat by repeat (so a drift of the machine's speed hits all of
them alike). Prints and writes, per chunk: median and minimum seconds per frame's calls, the ratio
to the largest chunk measured in this run, and the ratio :func:`ipf_jax.likelihood.scorer.chunk_cost`
predicts; and the chunking :func:`~ipf_jax.likelihood.scorer.pick_chunking` chooses for the filter.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from ipf_jax.body.limits import load_limits
from ipf_jax.filters import registry
from ipf_jax.likelihood.scorer import call_blocks, chunk_cost, pick_chunking
from ipf_jax.paths import shared_data_dir
from ipf_jax.profiling import DATASET, device_line, load_scene, machine, measure_step


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", required=True, type=Path, help="output file")
    ap.add_argument("--filter", default=registry.DEFAULT, choices=registry.NAMES)
    ap.add_argument("--budget", type=int, default=6561, help="evaluations per frame")
    ap.add_argument("--chunks", default="128,216,256,512", help="chunk sizes, comma-separated")
    ap.add_argument("--cameras", type=int, default=4)
    ap.add_argument("--width", type=int, default=320)
    ap.add_argument("--repeats", type=int, default=7)
    args = ap.parse_args(argv)
    chunks = sorted({int(c) for c in args.chunks.split(",")})
    calls = registry.make(args.filter, {}, load_limits("default"), 20.0, budget=args.budget).calls
    print(device_line())
    scene = load_scene(shared_data_dir() / DATASET, args.width, args.cameras, max(calls))
    fns = {c: measure_step("jax-scanline", scene, chunk=c, calls=calls) for c in chunks}
    chunkings = {c: pick_chunking(calls, chunk=c) for c in chunks}
    for fn in fns.values():  # compile (or load) every shape first
        for n in sorted(set(calls)):
            fn(scene.particles[:n])
    times = {c: [] for c in chunks}
    for _ in range(args.repeats):
        for c, fn in fns.items():
            t0 = time.perf_counter()
            for n in calls:
                fn(scene.particles[:n])
            times[c].append(time.perf_counter() - t0)
    ref = max(chunks)
    rows = []
    for c in chunks:
        med = float(np.median(times[c]))
        rows.append({"chunk": c, "median_s": round(med, 4), "min_s": round(min(times[c]), 4),
                     "ratio_to_largest": round(med / float(np.median(times[ref])), 3),
                     "model_ratio": round(chunk_cost(calls, chunkings[c])
                                          / chunk_cost(calls, chunkings[ref]), 3),
                     "chunks_per_call": chunkings[c].block,
                     "particles_rasterised": int(sum(-(-n // c) * c for n in calls)),
                     "compiled_calls": int(sum(len(call_blocks(n, chunkings[c])) for n in calls))})
    doc = {"filter": args.filter, "budget": args.budget, "calls": list(calls), "cameras": args.cameras,
           "width": args.width, "repeats": args.repeats, "picked_chunk": list(pick_chunking(calls)),
           "machine": machine(), "rows": rows}
    args.json.write_text(json.dumps(doc, indent=1))
    print(f"{args.filter} calls {list(calls)}: pick_chunking -> {doc['picked_chunk']} (chunk, block)")
    print("chunk  median s  min s  ratio  model  rasterised  calls")
    for r in rows:
        print(f"{r['chunk']:5d}  {r['median_s']:8.4f}  {r['min_s']:.4f}  {r['ratio_to_largest']:.3f}  "
              f"{r['model_ratio']:.3f}  {r['particles_rasterised']:10d}  {r['compiled_calls']:5d}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
