"""Where the time of the JAX measure step goes: each compiled stage timed alone.

    python benchmarks/stages.py [--width 320] [--cameras 1] [--particles 6561] [--repeats 7]

Times, on the fixed bench scene (see ``ipf_jax.profiling``), one chunk through each stage of
``ipf_jax.likelihood.scorer.Scorer`` (geometry for all cameras; then, per camera, the row intervals, the
words/popcount, and the dense kernel's intervals), with ``block_until_ready`` and the median of
repeats, in wall and process-CPU seconds per particle. The sum of the stages is the ceiling of the
whole measure step at that chunk size; the rest is host work (window plan, transfers, weights).
"""
import argparse
import time
from pathlib import Path

import jax
import numpy as np

from ipf_jax import jax_setup
from ipf_jax.likelihood import scorer as lk
from ipf_jax.paths import shared_data_dir
from ipf_jax.profiling import DATASET, load_scene


def timed(fn, repeats):
    jax.block_until_ready(fn())  # warm-up: compile
    wall, cpu = [], []
    for _ in range(repeats):
        t, c = time.perf_counter(), time.process_time()
        jax.block_until_ready(fn())
        wall.append(time.perf_counter() - t)
        cpu.append(time.process_time() - c)
    return float(np.median(wall)), float(np.median(cpu))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--width", type=int, default=320)
    ap.add_argument("--cameras", type=int, default=1)
    ap.add_argument("--particles", type=int, default=6561)
    ap.add_argument("--chunk", type=int, default=512)
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--data", default=str(shared_data_dir() / DATASET))
    args = ap.parse_args()
    jax_setup.configure()
    scene = load_scene(Path(args.data), args.width, args.cameras, args.particles)
    obs = lk.make_observation(scene.masks)
    s = lk.Scorer(scene.cameras, scene.shape, scene.up, chunk=args.chunk)
    whole = timed(lambda: s.counts(scene.particles, obs), args.repeats)
    caps, ext = s.geometry(scene.particles)
    win = s.plan(ext)
    block = scene.particles[:s.chunk].astype(np.float32)
    stages = {"geometry (all cameras)": lambda: lk._geometry_jit(block, s.shape_values, s.up, s.cams,
                                                                 long_side=s.long_side)}
    for c in range(args.cameras):
        cap, h, w, sz = caps[0][c], s.heights[c], s.widths[c], s.sizes[c]
        packed = lk._intervals_jit(cap, win.win_rows[c], h, w, n_win=sz.win_rows, q=s.q, long_side=s.long_side)
        stages[f"intervals cam {c + 1}"] = lambda cap=cap, c=c, h=h, w=w, sz=sz: lk._intervals_jit(
            cap, win.win_rows[c], h, w, n_win=sz.win_rows, q=s.q, long_side=s.long_side)
        stages[f"words cam {c + 1}"] = lambda packed=packed, c=c, sz=sz: lk._words_jit(
            packed, obs.words[c], win.row0[c], win.word0[c], win.win_rows[c], win.win_words[c],
            n_win_words=sz.win_words, n_rows=sz.rows, n_words=sz.words)
        stages[f"dense intervals cam {c + 1}"] = lambda cap=cap, c=c, h=h, w=w, sz=sz: lk._dense_jit(
            cap, win.win_rows[c], win.win_words[c], h, w, n_win=sz.win_rows, n_win_words=sz.win_words,
            q=s.q, long_side=s.long_side)
    print(f"{args.width}x{scene.masks[0].shape[0]}, {args.cameras} camera(s), chunk {s.chunk}, "
          f"sizes {[tuple(z) for z in s.sizes]}, device {jax.devices()[0].device_kind}, jax {jax.__version__}")
    print(f"{'stage':28s} {'us/particle wall':>17s} {'us/particle cpu':>16s} {'particles/s':>12s}")
    scanline_sum = 0.0
    for name, fn in stages.items():
        wall, cpu = timed(fn, args.repeats)
        if not name.startswith("dense"):
            scanline_sum += wall / s.chunk
        print(f"{name:28s} {wall / s.chunk * 1e6:17.2f} {cpu / s.chunk * 1e6:16.2f} {s.chunk / wall:12.0f}")
    n = len(scene.particles)
    print(f"{'sum of scanline stages':28s} {scanline_sum * 1e6:17.2f} {'':16s} {1 / scanline_sum:12.0f}")
    print(f"{'Scorer.counts (whole)':28s} {whole[0] / n * 1e6:17.2f} {whole[1] / n * 1e6:16.2f} {n / whole[0]:12.0f}")


if __name__ == "__main__":
    main()
