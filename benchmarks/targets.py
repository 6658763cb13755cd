"""The issue's speed targets, measured interleaved so that a busy machine slows every side alike.

    python benchmarks/targets.py [--rounds 5] [--json FILE]

1. 1 camera at 320x240: particles/s of the measure step for jax-scanline (6561 poses),
   numpy-scanline (512) and numpy-reference (8), one call of each per round, medians over the
   rounds, and the ratios (targets: >= 50,000/s, >= 100x the reference, >= 10x numpy-scanline).
2. 6561 particles x 4 cameras x 640x480: peak RSS of the measure step (target <= 2 GB).

Wall and process-CPU seconds are both reported: on a shared machine the CPU-time rate
(particles per CPU-second) is the one other processes disturb least.
"""
import argparse
import json
import time
from pathlib import Path

import numpy as np

from ipf_jax import jax_setup
from ipf_jax.paths import shared_data_dir
from ipf_jax.profiling import DATASET, bench_measure, load_scene, machine, measure_step


def interleaved(scene, sizes: dict, rounds: int) -> dict:
    fns = {b: measure_step(b, scene) for b in sizes}
    for b, fn in fns.items():
        fn(scene.particles[:sizes[b]])  # warm-up (compiles)
    wall, cpu = {b: [] for b in fns}, {b: [] for b in fns}
    for _ in range(rounds):
        for b, fn in fns.items():
            t, c = time.perf_counter(), time.process_time()
            fn(scene.particles[:sizes[b]])
            wall[b].append(time.perf_counter() - t)
            cpu[b].append(time.process_time() - c)
    return {b: {"particles": n, "particles_per_s": n / float(np.median(wall[b])),
                "particles_per_cpu_s": n / float(np.median(cpu[b]))} for b, n in sizes.items()}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--data", default=str(shared_data_dir() / DATASET))
    ap.add_argument("--json", help="also write the results here")
    args = ap.parse_args()
    jax_setup.configure()
    data = Path(args.data)
    t0 = time.perf_counter()
    c0 = time.process_time()
    scene = load_scene(data, 320, 1, 6561)
    res = interleaved(scene, {"jax-scanline": 6561, "numpy-scanline": 512, "numpy-reference": 8},
                      args.rounds)
    js = res["jax-scanline"]
    print("1 camera, 320x240 (medians over interleaved rounds)")
    for b, r in res.items():
        print(f"  {b:16s} {r['particles']:6d} poses  {r['particles_per_s']:10,.0f} /s wall"
              f"  {r['particles_per_cpu_s']:10,.0f} /CPU-s   x{js['particles_per_s'] / r['particles_per_s']:,.1f}"
              f" (CPU x{js['particles_per_cpu_s'] / r['particles_per_cpu_s']:,.1f})")
    rec, _ = bench_measure("jax-scanline", load_scene(data, 640, 4, 6561), 6561, repeats=2)
    print(f"6561 x 4 cameras x 640x480: peak RSS {rec['peak_rss_mb']:.0f} MB "
          f"(exact per record: {rec['peak_rss_exact']}), {rec['particles_per_s']:,.0f} particles/s")
    share = (time.process_time() - c0) / (time.perf_counter() - t0)
    print(f"this process ran on {share:.2f} of a core on average (2 = both cores to itself)")
    if args.json:
        Path(args.json).write_text(json.dumps({"machine": machine(), "one_camera_320": res,
                                               "rss_6561_4cam_640": rec, "core_share": share},
                                              indent=1))


if __name__ == "__main__":
    main()
