"""The raster's row solve and its coefficient stage, this tree against another checkout, in one
process on the same inputs.

    python benchmarks/raster_ab.py --tree <checkout> [--cameras 1] [--width 320] [--rounds 15]
                                   [--json out.json]

Loads ``<checkout>/ipf_jax/likelihood/raster.py`` beside this tree's and times, alternately, on
the bench scene's first chunk (``ipf_jax.profiling``: sequenceB_2, 6561 poses, chunks of 512):

* **intervals**: the scanline stage 1 (``list_intervals``) on each camera's row list, from each
  module's own coefficients (their packed intervals must be equal, or the script stops);
* **coefficients**: the geometry stage up to the coefficients (capsule records, extents,
  ``quantize`` and ``row_coeffs`` of every camera), which is where the two modules' coefficients
  are made.

Both with the scorer's XLA options. Reports the fastest and the median of ``--rounds``
alternations of 10 calls each (ms per chunk) and their ratio, other / this tree: above 1, this
tree is faster. Separate processes would see the machine's drift between them; one process sees
both under the same load.
"""
from __future__ import annotations

import argparse
import importlib.util
import json
import sys
import time
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

from ipf_jax import jax_setup, profiling
from ipf_jax.likelihood import raster, scorer
from ipf_jax.paths import shared_data_dir


def load_other(tree: Path):
    path = tree / "ipf_jax" / "likelihood" / "raster.py"
    if not path.is_file():
        sys.exit(f"raster_ab: {path} not found")
    spec = importlib.util.spec_from_file_location("ipf_jax.likelihood._raster_other", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def compiled(fn, *args):
    return jax.jit(fn).lower(*args).compile(scorer.COMPILER_OPTIONS)


def alternate(calls: dict, rounds: int) -> dict:
    times = {k: [] for k in calls}
    for _ in range(rounds):
        for k, f in calls.items():
            t = time.perf_counter()
            for _ in range(10):
                jax.block_until_ready(f())
            times[k].append((time.perf_counter() - t) / 10)
    return {k: {"min_ms": round(float(np.min(v)) * 1e3, 4), "median_ms": round(float(np.median(v)) * 1e3, 4)}
            for k, v in times.items()}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tree", required=True, type=Path, help="the other checkout")
    ap.add_argument("--cameras", type=int, default=1)
    ap.add_argument("--width", type=int, default=320)
    ap.add_argument("--rounds", type=int, default=15)
    ap.add_argument("--data", default=str(shared_data_dir() / profiling.DATASET))
    ap.add_argument("--json")
    args = ap.parse_args()
    jax_setup.configure()
    other = load_other(args.tree)
    mods = {"this": raster, "other": other}
    scene = profiling.load_scene(Path(args.data), args.width, args.cameras, 6561)
    s = scorer.Scorer(scene.cameras, scene.shape, scene.up, chunk=512)
    _, ext = s.geometry(scene.particles, kernel="scanline")
    fields, _ = s.geometry(scene.particles[:512], kernel="dense")  # 15 x (1, C, S, B)
    records = [jnp.stack(fields[0], axis=2)]  # (1, C, 15, S, B)
    win = s.plan(ext)
    q, long_side = s.q, s.long_side
    block = jnp.asarray(np.ascontiguousarray(scene.particles[:512].T, np.float32))
    shape_values = jnp.asarray(np.asarray(s.shape_values))

    def coefficients(mod, caps, axis):
        """A tree's row coefficients of records whose field axis is ``axis``, the way its scorer
        computes them: field by field where the tree has ``quantize_fields``, else through
        ``quantize`` on the records with the fields last."""
        if hasattr(mod, "quantize_fields"):
            qf = mod.quantize_fields(jnp, lambda i: jnp.take(caps, i, axis=axis), q, long_side)
            return mod.row_coeffs(jnp, qf, q)
        by_seg = jnp.moveaxis(caps, axis, -1)
        return mod.row_coeffs(jnp, mod.quantize(jnp, by_seg, q, long_side), q)

    def coefficient_stage(mod):
        def fn(qt, sv, up, cams):
            caps = jax.lax.optimization_barrier(scorer.capsule_fields(qt, sv, up, cams))
            by_seg = jnp.moveaxis(caps, 1, -1)
            ext = raster.segment_extent(jnp, by_seg, long_side)
            union = jnp.stack([ext[..., 0].min(2), ext[..., 1].max(2), ext[..., 2].min(2),
                               ext[..., 3].max(2)], -1)
            return coefficients(mod, caps, 1), union
        f = compiled(fn, block, shape_values, s.up, s.cams)
        return lambda: f(block, shape_values, s.up, s.cams)

    out = {"tree": str(args.tree), "cameras": args.cameras, "width": args.width, "chunk": 512,
           "device": jax.devices()[0].device_kind, "jax": jax.__version__, "stages": {}}
    calls = {}
    for c in range(args.cameras):
        h, w, rows = s.heights[c], s.widths[c], win.rows[c]
        packed = {}
        for name, mod in mods.items():
            rc = jax.jit(lambda x, mod=mod: coefficients(mod, x, 0))(records[0][0, c])
            f = compiled(lambda r, l, mod=mod, h=h, w=w: mod.list_intervals(r, l, q, h, w), rc, rows)
            calls[f"intervals cam {c + 1} {name}"] = lambda f=f, rc=rc, rows=rows: f(rc, rows)
            packed[name] = np.asarray(f(rc, rows))
        if not np.array_equal(packed["this"], packed["other"]):
            sys.exit(f"raster_ab: camera {c + 1}: the two trees' intervals differ "
                     f"({int((packed['this'] != packed['other']).sum())} entries)")
    for name, mod in mods.items():
        calls[f"coefficients {name}"] = coefficient_stage(mod)
    res = alternate(calls, args.rounds)
    for stage in ["coefficients"] + [f"intervals cam {c + 1}" for c in range(args.cameras)]:
        a, b = res[f"{stage} this"], res[f"{stage} other"]
        row = {"this": a, "other": b, "other_over_this_min": round(b["min_ms"] / a["min_ms"], 3),
               "other_over_this_median": round(b["median_ms"] / a["median_ms"], 3)}
        out["stages"][stage] = row
        print(f"{stage:18s} this {a['min_ms']:.3f} ({a['median_ms']:.3f}) ms, other {b['min_ms']:.3f} "
              f"({b['median_ms']:.3f}) ms per chunk: other / this {row['other_over_this_min']:.2f} "
              f"(medians {row['other_over_this_median']:.2f})")
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=1) + "\n")


if __name__ == "__main__":
    main()
