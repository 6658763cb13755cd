"""What the scoring resolution costs and buys: APF seconds/frame against accuracy on sequenceB_2.

    python benchmarks/resolution.py [--widths 64,80,120,160,320,640] [--seeds 3] [--json FILE]

For each scoring width (4 cameras, the exact scanline likelihood):

* ``agreement``: on the fixed bench scene (6561 poses around the person, see ``ipf_jax.profiling``),
  how well the weights at that width rank the poses like the weights at the native 640x480: the
  Spearman rank correlation, and where the native-resolution best pose ranks at this width;
* ``apf``: bodytrack's budget (4000 particles x 5 layers), frame 1 of sequenceB_2 started from
  InitialPose.txt: seconds per frame (median over the runs after a warm-up) and the mean distance
  of the 12 limb joints to bodytrack's own frame-1 estimate (4000x5, serial), per seed.
"""
import argparse
import json
from pathlib import Path

import numpy as np

from ipf_jax import jax_setup
from ipf_jax.paths import shared_data_dir
from ipf_jax.profiling import (
    DATASET,
    PEER_POSES,
    bench_track,
    load_scene,
    measure_step,
    rank_agreement,
)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--widths", default="64,80,120,160,320,640")
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--runs", type=int, default=2, help="timed runs per seed after the warm-up")
    ap.add_argument("--data", default=str(shared_data_dir() / DATASET))
    ap.add_argument("--json", help="also write the rows here")
    args = ap.parse_args()
    jax_setup.configure()
    data = Path(args.data)
    widths = [int(w) for w in args.widths.split(",")]
    native = max(640, *widths)
    weights = {}
    for w in sorted(set(widths + [native])):
        scene = load_scene(data, w, 4, 6561)
        weights[w] = measure_step("jax-scanline", scene)(scene.particles)
    best_native = int(np.argmax(weights[native]))
    rows = []
    print("| width | rank corr. vs 640 | rank of the 640 best | APF s/frame | joint distance to bodytrack (m), per seed |")
    print("|---|---:|---:|---:|---|")
    for w in widths:
        order = np.argsort(-weights[w])
        rank = int(np.nonzero(order == best_native)[0][0]) + 1
        tracks = [bench_track(data, "apf", w, runs=args.runs, seed=s, peer=data.parent / Path(PEER_POSES).name)
                  for s in range(args.seeds)]
        secs = float(np.median([t["seconds_per_frame"] for t in tracks]))
        dists = [t.get("joint_distance_to_peer_m") for t in tracks]
        row = {"width": w, "rank_correlation_vs_native": round(rank_agreement(weights[w], weights[native]), 4),
               "rank_of_native_best": rank, "apf_seconds_per_frame": round(secs, 4),
               "joint_distance_to_peer_m": dists, "tracks": tracks}
        rows.append(row)
        print(f"| {w} | {row['rank_correlation_vs_native']:.3f} | {rank} | {secs:.3f} | "
              f"{', '.join(f'{d:.4f}' for d in dists if d is not None)} |", flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
