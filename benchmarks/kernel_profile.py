"""Where one measure call's device time goes, kernel by kernel (XLA's own trace).

    python benchmarks/kernel_profile.py [--stage counts|geometry] [--width 320] [--cameras 4]
        [--particles 4000] [--threads 1] [--repeats 5] [--top 25] [--json FILE]

Runs the scorer on the fixed bench scene (``ipf_jax.profiling``) under ``jax.profiler`` and reads
the trace back (``jax.profiler.ProfileData``): every kernel XLA's CPU runtime launched (fusions
and copies; a loop counts by the kernels it launches), its time and launches per call, beside the
call's wall time. ``perf`` cannot name JIT-compiled code; this can. A parallel kernel is timed on
each thread it runs on, so the kernels' sum may exceed the wall time. Classes: ``copy`` (plain
buffer copies, e.g. a loop's outputs filled with zeros before its first iteration), ``loop
writes`` (fusions ending in a dynamic-update-slice: a ``lax.map`` iteration computing its results
into the stacked outputs, or a window OR-ed into the union grid), ``other`` (the arithmetic).
``--threads 1`` keeps one host thread, so the calls' programs do not overlap.
"""
import argparse
import collections
import glob
import json
import re
import shutil
import tempfile
import time
from pathlib import Path

import jax
import numpy as np

from ipf_jax import jax_setup, profiling
from ipf_jax.paths import shared_data_dir

#: Trace events that are host-side frames, runtime bookkeeping or loops (a loop's event spans the
#: kernels it launches), not kernels.
NOT_KERNELS = ("$", "ThunkExecutor", "PjitFunction", "DevicePut", "CommonPjRt", "while", "end: ")


def kernel_class(name: str) -> str:
    if re.fullmatch(r"copy(\.\d+)?", name):
        return "copy"
    if "dynamic-update-slice" in name:
        return "loop writes"
    return "other"


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--stage", choices=("counts", "geometry"), default="counts",
                    help="counts: a whole Scorer.counts call; geometry: its stage 1 alone")
    ap.add_argument("--width", type=int, default=320)
    ap.add_argument("--cameras", type=int, default=4)
    ap.add_argument("--particles", type=int, default=4000)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--top", type=int, default=25)
    ap.add_argument("--json", help="write the profile here")
    ap.add_argument("--data", default=str(shared_data_dir() / profiling.DATASET))
    args = ap.parse_args()
    jax_setup.configure()
    from ipf_jax.likelihood.scorer import Scorer, make_observation, pick_chunking

    scene = profiling.load_scene(Path(args.data), args.width, args.cameras, args.particles)
    n = len(scene.particles)
    cut = pick_chunking([n])
    s = Scorer(scene.cameras, scene.shape, scene.up, chunk=cut.chunk, block=cut.block,
               threads=args.threads)
    obs = make_observation(scene.masks)
    cuts = s._spread(s._blocks(n))
    if args.stage == "counts":
        def call():
            s.counts(scene.particles, obs)
    else:
        def call():  # each call writes into the last one's records, as Scorer.counts runs it
            recs = s.geometry(scene.particles, cuts=cuts)[0]
            jax.block_until_ready(recs)
            s._recycle(cuts, recs, s.q)
    for _ in range(3):  # compiled, loaded, windows settled
        call()
    walls = []
    trace_dir = tempfile.mkdtemp(prefix="ipf-kernels-")
    try:
        jax.profiler.start_trace(trace_dir)
        for _ in range(args.repeats):
            t = time.perf_counter()
            call()
            walls.append(time.perf_counter() - t)
        jax.profiler.stop_trace()
        data = jax.profiler.ProfileData.from_file(
            sorted(glob.glob(f"{trace_dir}/**/*.xplane.pb", recursive=True))[-1])
        total, launches = collections.Counter(), collections.Counter()
        for plane in data.planes:
            for line in plane.lines:
                for ev in line.events:
                    if not ev.name.startswith(NOT_KERNELS) and "Execute" not in ev.name:
                        total[ev.name] += ev.duration_ns
                        launches[ev.name] += 1
    finally:
        shutil.rmtree(trace_dir, ignore_errors=True)
    r = args.repeats
    kernel_ms = sum(total.values()) / 1e6 / r
    wall_ms = float(np.median(walls)) * 1e3
    by_class = collections.Counter()
    for name, ns in total.items():
        by_class[kernel_class(name)] += ns
    print(f"{args.stage}: {n} particles, {args.cameras} camera(s), {args.width} px, chunks "
          f"{[(k, b) for _, _, k, b in cuts]}, {args.threads} thread(s), device "
          f"{jax.devices()[0].device_kind}, jax {jax.__version__}")
    print(f"wall {wall_ms:.2f} ms per call (median of {r}; traced), {wall_ms * 1e3 / n:.2f} us per "
          f"particle; kernels {kernel_ms:.2f} ms per call over {sum(launches.values()) / r:.0f} "
          f"launches of {len(total)} kernels")
    for cls, ns in by_class.most_common():
        print(f"  {cls:12s} {ns / 1e6 / r:8.2f} ms  {100 * ns / max(sum(total.values()), 1):5.1f} %")
    print(f"{'kernel':48s} {'ms/call':>8s} {'launches':>9s} {'share':>6s}")
    rows = []
    for name, ns in total.most_common():
        rows.append({"kernel": name, "ms_per_call": ns / 1e6 / r, "launches_per_call": launches[name] / r,
                     "class": kernel_class(name)})
    for row in rows[:args.top]:
        print(f"{row['kernel'][:48]:48s} {row['ms_per_call']:8.3f} {row['launches_per_call']:9.1f} "
              f"{100 * row['ms_per_call'] / max(kernel_ms, 1e-12):5.1f}%")
    if args.json:
        Path(args.json).write_text(json.dumps({
            "stage": args.stage, "particles": n, "cameras": args.cameras, "width": args.width,
            "threads": args.threads, "chunks": [[k, b] for _, _, k, b in cuts],
            "device": jax.devices()[0].device_kind, "jax": jax.__version__, "wall_ms": wall_ms,
            "kernel_ms": kernel_ms, "launches_per_call": sum(launches.values()) / r,
            "by_class_ms": {c: ns / 1e6 / r for c, ns in by_class.items()}, "kernels": rows}, indent=1))


if __name__ == "__main__":
    main()
