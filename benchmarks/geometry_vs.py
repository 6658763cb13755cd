"""The geometry stage against an older revision's, both compiled in one process and timed in turn.

    git worktree add /tmp/wt-81f 81f2241
    python benchmarks/geometry_vs.py --tree /tmp/wt-81f [--width 80] [--cameras 4]
                                     [--particles 4000] [--rounds 9] [--json FILE]

Issue 20's geometry benchmark (``stages.py --width 80 --cameras 4 --particles 4000``) run as
ratios measured side by side: two processes timed one after the other on this machine kind
drift by up to 2x (docs/benchmarks.md), pairs in one process much less. ``--tree`` is a checkout
of a revision with 81f2241's layout (``ipf_jax/likelihood.py`` with ``Scorer`` and
``_geometry_jit``, ``ipf_jax/bench.py`` with ``load_scene``); its package is copied into a
temporary folder under another name (its ``ipf_jax`` imports renamed), so both import here.

Per round, in turn, us per particle (wall, median of 11 calls):

* ``other``: the other tree's geometry stage on one chunk of 512 particles, as its stages
  benchmark timed it (FK, the capsule records of every camera, the extents);
* ``records only``: today's block program (the tracker's chunking of ``--particles``) writing the
  same outputs (the 15 record fields and the extents);
* ``tracker``: the same block with the row coefficients instead of the records, as
  :meth:`~ipf_jax.likelihood.scorer.Scorer.counts` runs it (more work than the other tree's
  stage did: its row stage quantised the records).

Both score today's bench particles (each tree with its own bench body); the records are compared
(today's sines and cosines are a polynomial: they differ in the last bits, so the largest
difference in pixels is printed, not asserted; where the trees' bench bodies differ it says so).
"""
import argparse
import importlib
import json
import re
import shutil
import sys
import tempfile
from pathlib import Path

import jax
import numpy as np

from ipf_jax import jax_setup, profiling
from ipf_jax.likelihood import scorer as S
from ipf_jax.paths import shared_data_dir

ALIAS = "ipf_jax_other"


def import_tree(tree: Path, into: Path):
    """The package of ``tree`` imported as :data:`ALIAS` (a renamed copy in ``into``)."""
    src = tree / "ipf_jax"
    if not (src / "likelihood.py").is_file() or not (src / "bench.py").is_file():
        sys.exit(f"geometry_vs: {tree} has not 81f2241's layout (ipf_jax/likelihood.py, ipf_jax/bench.py)")
    dst = into / ALIAS
    shutil.copytree(src, dst, ignore=shutil.ignore_patterns("__pycache__"))
    for py in dst.rglob("*.py"):
        py.write_text(re.sub(r"\bipf_jax\b", ALIAS, py.read_text()))
    sys.path.insert(0, str(into))
    return importlib.import_module(f"{ALIAS}.likelihood"), importlib.import_module(f"{ALIAS}.bench")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tree", type=Path, required=True)
    ap.add_argument("--width", type=int, default=80)
    ap.add_argument("--cameras", type=int, default=4)
    ap.add_argument("--particles", type=int, default=4000)
    ap.add_argument("--rounds", type=int, default=9)
    ap.add_argument("--data", default=str(shared_data_dir() / profiling.DATASET))
    ap.add_argument("--json", help="write the rounds here")
    args = ap.parse_args()
    jax_setup.configure()
    # the copy stays until the end: the other tree's modules import some of theirs lazily
    with tempfile.TemporaryDirectory(prefix="geometry-vs-") as tmp:
        compare(args, *import_tree(args.tree, Path(tmp)))


def compare(args, other_lk, other_bench):
    """Time the other tree's stage and today's block programs in turn (module doc)."""
    scene = profiling.load_scene(Path(args.data), args.width, args.cameras, args.particles)
    old_scene = other_bench.load_scene(Path(args.data), args.width, args.cameras, args.particles)
    if scene.particles.shape != old_scene.particles.shape:
        sys.exit("geometry_vs: the two trees' bench scenes have particles of other sizes")
    same_scene = (np.array_equal(scene.particles, old_scene.particles)
                  and np.array_equal(scene.shape.values, old_scene.shape.values))

    old = other_lk.Scorer(old_scene.cameras, old_scene.shape, old_scene.up, chunk=512)
    old_chunk = np.asarray(scene.particles[:old.chunk], np.float32)  # both score today's particles

    def run_other():
        return other_lk._geometry_jit(old_chunk, old.shape_values, old.up, old.cams, long_side=old.long_side)

    cut = S.pick_chunking([args.particles])
    s = S.Scorer(scene.cameras, scene.shape, scene.up, chunk=cut.chunk, block=cut.block)
    _, _, k, b = s._blocks(args.particles)[0]
    block = s._put(s._block(scene.particles, 0, min(args.particles, k * b), k, b), True)
    held = {q: [S.record_buffers(k, b, args.cameras, q, s._device)] for q in (0, s.q)}

    def today(q):
        def run():  # into the last call's buffers, as Scorer.counts runs it
            held[q][0], ext = S._geometry_calls_jit(block, s.shape_values, s.up, s.cams, held[q][0],
                                                    long_side=s.long_side, scan_q=q)
            return held[q][0], ext
        return run

    calls = {"other": (run_other, old.chunk), "records only": (today(0), k * b),
             "tracker": (today(s.q), k * b)}
    for run, _ in calls.values():
        jax.block_until_ready(run())
    theirs = run_other()[0]  # C arrays (B, S, 15)
    ours = calls["records only"][0]()[0]  # 15 fields (K, C, S, B)
    if not isinstance(ours, tuple):  # a revision before the fields: (K, C, 15, S, B)
        ours = tuple(np.asarray(ours)[:, :, i] for i in range(15))
    n = min(b, old.chunk)
    diff = max(float(np.abs(np.asarray(ours[i])[0, c, :, :n].T - np.asarray(theirs[c])[:n, :, i]).max())
               for c in range(args.cameras) for i in range(15))
    print(f"{args.width}px, {args.cameras} camera(s); other: {args.tree} on one chunk of {old.chunk}; "
          f"today: a block of {k} x {b}; device {jax.devices()[0].device_kind}")
    note = "" if same_scene else "; the trees' bench bodies or noise differ, so only the timing compares"
    print(f"records: largest difference {diff:.2e} px (first {n} particles, every field and camera{note})")
    rounds = {name: [] for name in calls}
    for r in range(args.rounds):
        for name, (run, count) in calls.items():
            rounds[name].append(profiling.timed(run, 11)[0] / count * 1e6)
        print(f"round {r + 1}: " + ", ".join(f"{name} {v[-1]:.2f}" for name, v in rounds.items())
              + f" us/particle; other / records only {rounds['other'][-1] / rounds['records only'][-1]:.2f}, "
              f"other / tracker {rounds['other'][-1] / rounds['tracker'][-1]:.2f}")
    ratios = {f"other / {name}": [o / t for o, t in zip(rounds["other"], rounds[name])]
              for name in ("records only", "tracker")}
    for name, v in ratios.items():
        print(f"{name}: median {np.median(v):.2f} (rounds {min(v):.2f}-{max(v):.2f})")
    if args.json:
        Path(args.json).write_text(json.dumps({
            "tree": str(args.tree), "width": args.width, "cameras": args.cameras,
            "particles": args.particles, "block": [k, b], "other_chunk": old.chunk,
            "device": jax.devices()[0].device_kind, "jax": jax.__version__,
            "cpu": jax_setup.host_cpu(), "records_max_diff_px": diff, "same_scene": same_scene,
            "us_per_particle": rounds, "ratios": ratios,
            "medians": {name: float(np.median(v)) for name, v in ratios.items()}}, indent=1))


if __name__ == "__main__":
    main()
