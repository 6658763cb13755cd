"""The geometry stage against a variant of itself, both compiled in one process and timed in turn.

    python benchmarks/geometry_ab.py --variant trig|per-camera|stacked [--width 80] [--cameras 4]
                                     [--particles 4000] [--rounds 9]

Reproduces the changes of 2026-12-06 (seventeenth and eighteenth sessions, docs/benchmarks.md) as
ratios measured side by side, which survive the machine's drifts better than two processes do:

* ``trig``: the joint angles' cosines and sines from XLA's ``cos`` / ``sin`` (the code before
  :mod:`ipf_jax.geometry.trig`) against the polynomial of that module: the batched kinematics
  alone (:func:`~ipf_jax.geometry.kinematics.capsule_ends`) and the geometry program of one
  chunk (``--particles`` at most one chunk) or of the tracker's block.
* ``per-camera``: the block program with one output per camera and field (the layout before)
  against the cameras in one array per field (today's).
* ``stacked``: the block program writing records only (the dense kernel's geometry, and 81f2241's
  outputs) as one (C, 15, S, B) stack per chunk (the layout before) against its 15 fields as
  separate outputs (today's).

The tracker's chunking for one call of ``--particles`` sets the block (K chunks of B); the
variant's outputs are checked to equal today's where they must (``per-camera``: the same
numbers; ``trig``: the records may differ in the last bits). Prints per round the us per
particle of each and the ratio variant / today (> 1: today's is faster).
"""
import argparse
from pathlib import Path

import jax
import numpy as np

from ipf_jax import jax_setup, profiling
from ipf_jax.geometry import kinematics
from ipf_jax.likelihood import scorer as S
from ipf_jax.paths import shared_data_dir


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--variant", choices=("trig", "per-camera", "stacked"), required=True)
    ap.add_argument("--width", type=int, default=80)
    ap.add_argument("--cameras", type=int, default=4)
    ap.add_argument("--particles", type=int, default=4000)
    ap.add_argument("--rounds", type=int, default=9)
    ap.add_argument("--data", default=str(shared_data_dir() / profiling.DATASET))
    args = ap.parse_args()
    jax_setup.configure()
    scene = profiling.load_scene(Path(args.data), args.width, args.cameras, args.particles)
    cut = S.pick_chunking([args.particles])
    s = S.Scorer(scene.cameras, scene.shape, scene.up, chunk=cut.chunk, block=cut.block)
    _, _, k, b = s._blocks(args.particles)[0]
    block = s._block(scene.particles, 0, min(args.particles, k * b), k, b)
    sv, up, cams = s.shape_values, s.up, s.cams

    scan_q = 0 if args.variant == "stacked" else s.q

    def geometry():
        f = jax.jit(lambda q: S._geometry_calls_impl(q, sv, up, cams, None, s.long_side, scan_q))
        return f.lower(block).compile(S.COMPILER_OPTIONS)

    def kin():
        q_t = np.ascontiguousarray(block.reshape(k * b, -1).T)
        f = jax.jit(lambda q: kinematics.capsule_ends(q, sv, up))
        return lambda c=f.lower(q_t).compile(S.COMPILER_OPTIONS): c(q_t)

    programs = {"geometry": [geometry()]}
    if args.variant == "trig":
        programs["kinematics"] = [kin()]
        kinematics.sincos = lambda xp, x: (xp.cos(x), xp.sin(x))  # the code before trig.py
        programs["geometry"].append(geometry())
        programs["kinematics"].append(kin())
    elif args.variant == "stacked":
        today_records = S._records

        def stacked(discs, long_side, scan_q_):
            caps, union = today_records(discs, long_side, scan_q_)
            return jax.numpy.stack(caps, axis=1), union

        S._records = stacked
        S._record_layout.cache_clear()
        programs["geometry"].append(geometry())
        today = programs["geometry"][0](block)[0]
        other = np.asarray(programs["geometry"][1](block)[0])
        same = all(np.array_equal(np.asarray(t), other[:, :, i]) for i, t in enumerate(today))
        print(f"stacked records equal today's fields: {same}")
    else:
        today_records = S._records

        def per_camera(discs, long_side, scan_q):
            rc, union = today_records(discs, long_side, scan_q)
            return tuple(jax.tree.map(lambda a, c=c: a[c], rc) for c in range(args.cameras)), union

        S._records = per_camera
        S._record_layout.cache_clear()
        programs["geometry"].append(geometry())
        today = jax.tree.leaves(programs["geometry"][0](block)[0])
        other = programs["geometry"][1](block)[0]
        same = all(np.array_equal(np.asarray(t)[:, c], np.asarray(o))
                   for c in range(args.cameras)
                   for t, o in zip(today, jax.tree.leaves(other[c])))
        print(f"per-camera outputs equal today's: {same}")
    n = k * b
    print(f"{args.width}px, {args.cameras} camera(s), block of {k} x {b}, device "
          f"{jax.devices()[0].device_kind}")
    for name, (new, old) in programs.items():
        run_new = new if name == "kinematics" else (lambda c=new: c(block))
        run_old = old if name == "kinematics" else (lambda c=old: c(block))
        t_new, t_old = [], []
        for _ in range(args.rounds):
            t_old.append(profiling.timed(run_old, 11)[0] / n * 1e6)
            t_new.append(profiling.timed(run_new, 11)[0] / n * 1e6)
        ratios = [o / t for o, t in zip(t_old, t_new)]
        print(f"{name}: variant {np.median(t_old):.2f}, today {np.median(t_new):.2f} us/particle "
              f"(medians); ratio per round {' '.join(f'{r:.2f}' for r in ratios)}, "
              f"median {np.median(ratios):.2f}")


if __name__ == "__main__":
    main()
