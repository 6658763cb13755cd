"""Where the time of the JAX measure step goes: each compiled stage timed alone.

    python benchmarks/stages.py [--width 320] [--cameras 1] [--particles 6561] [--repeats 7]

Times, on the fixed bench scene (see ``ipf_jax.profiling``), one chunk through each stage of the
scorer (geometry for all cameras; then, per camera, the row intervals, the words/popcount, and the
dense kernel's intervals; with ``--chunk 0`` also the tracker's block program, with and without
the row coefficients it now computes for the row stage: "records only" is the work the stage did
in revisions before them), with ``block_until_ready`` and the median of repeats, in wall and
process-CPU seconds per particle (:func:`ipf_jax.profiling.stage_timings`). The sum of the stages is
the ceiling of the whole measure step at that chunk size; the rest is host work (window plan,
transfers, weights).
"""
import argparse
from pathlib import Path

import jax

from ipf_jax import jax_setup, profiling
from ipf_jax.paths import shared_data_dir


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--width", type=int, default=320)
    ap.add_argument("--cameras", type=int, default=1)
    ap.add_argument("--particles", type=int, default=6561)
    ap.add_argument("--chunk", type=int, default=512,
                    help="particles per chunk; 0: the tracker's chunking for one call of "
                         "--particles (its block program is then timed too)")
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--data", default=str(shared_data_dir() / profiling.DATASET))
    args = ap.parse_args()
    jax_setup.configure()
    scene = profiling.load_scene(Path(args.data), args.width, args.cameras, args.particles)
    res = profiling.stage_timings(scene, chunk=args.chunk or None, repeats=args.repeats)
    chunk = res["chunk"]
    print(f"{args.width}x{scene.masks[0].shape[0]}, {args.cameras} camera(s), chunk {chunk}, "
          f"sizes {res['sizes']}, device {jax.devices()[0].device_kind}, jax {jax.__version__}")
    print(f"{'stage':36s} {'us/particle wall':>17s} {'us/particle cpu':>16s} {'particles/s':>12s}")
    scanline_sum = 0.0
    for name, (wall, cpu) in res["stages"].items():
        if not name.startswith(("dense", "geometry,")):  # one chunk through each scanline stage
            scanline_sum += wall / chunk
        print(f"{name:36s} {wall / chunk * 1e6:17.2f} {cpu / chunk * 1e6:16.2f} {chunk / wall:12.0f}")
    n = len(scene.particles)
    wall, cpu = res["whole"]
    print(f"{'sum of scanline stages':36s} {scanline_sum * 1e6:17.2f} {'':16s} {1 / scanline_sum:12.0f}")
    print(f"{'Scorer.counts (whole)':36s} {wall / n * 1e6:17.2f} {cpu / n * 1e6:16.2f} {n / wall:12.0f}")


if __name__ == "__main__":
    main()
