"""Markdown tables from ``ipf-jax bench --json`` results.

    python benchmarks/summarize.py benchmarks/results/<file>.json [more.json ...]

Prints: the machine; the measure-step throughput (particles/s) per backend, resolution, camera
count and particle count, with compile seconds and peak RSS; the speed-up of jax-scanline over
the NumPy backends measured in the same run; the tracking records (seconds per frame).
"""
import json
import sys
from collections import defaultdict


def load(paths):
    records = []
    for p in paths:
        with open(p) as fh:
            records += json.load(fh)
    return records


def machine(records):
    m = records[0].get("machine", {})
    return (f"{m.get('cpu', '?')}, {m.get('cores', '?')} cores, {m.get('memory_gb', '?')} GB, "
            f"{m.get('os', '?')}; Python {m.get('python', '?')}, NumPy {m.get('numpy', '?')}, "
            f"JAX {records[0].get('jax_version', '?')} ({records[0].get('device_kind', '?')})")


def measure_table(records):
    rows = [r for r in records if r.get("task", "measure") == "measure"]
    out = ["| backend | size | cameras | particles | particles/s | compile s | peak RSS MB |",
           "|---|---|---|---|---:|---:|---:|"]
    for r in sorted(rows, key=lambda r: (r["width"], r["cameras"], r["backend"], r["particles"])):
        comp = "" if r["compile_s"] is None else f"{r['compile_s']:.1f}"
        out.append(f"| {r['backend']} | {r['width']}x{r['height']} | {r['cameras']} | {r['particles']} | "
                   f"{r['particles_per_s']:,.0f} | {comp} | {r['peak_rss_mb']:.0f} |")
    return "\n".join(out)


def ratio_table(records):
    best = defaultdict(dict)  # (width, cameras) -> backend -> best particles/s
    for r in records:
        if r.get("task", "measure") != "measure":
            continue
        key = (r["width"], r["height"], r["cameras"])
        best[key][r["backend"]] = max(best[key].get(r["backend"], 0), r["particles_per_s"])
    out = ["| size | cameras | jax-scanline p/s | x jax-dense | x numpy-scanline | x numpy-reference |",
           "|---|---|---:|---:|---:|---:|"]
    for (w, h, c), b in sorted(best.items()):
        js = b.get("jax-scanline")
        if not js:
            continue
        cells = [f"{js / b[k]:,.0f}x" if b.get(k) else "" for k in ("jax-dense", "numpy-scanline",
                                                                      "numpy-reference")]
        out.append(f"| {w}x{h} | {c} | {js:,.0f} | " + " | ".join(cells) + " |")
    return "\n".join(out)


def track_table(records):
    rows = [r for r in records if r.get("task") == "track"]
    if not rows:
        return ""
    out = ["| filter | size | cameras | evaluations/frame | s/frame | joint distance to bodytrack (m) |"
           " peak RSS MB |", "|---|---|---|---:|---:|---:|---:|"]
    for r in rows:
        out.append(f"| {r['filter']} | {r['width']}x{r['height']} | {r['cameras']} | {r['particles']} | "
                   f"{r['seconds_per_frame']:.3f} | {r.get('joint_distance_to_peer_m', '')} | "
                   f"{r['peak_rss_mb']:.0f} |")
    return "\n".join(out)


def main():
    records = load(sys.argv[1:])
    print(f"Machine: {machine(records)}\n")
    print(ratio_table(records), "\n")
    print(measure_table(records), "\n")
    print(track_table(records))


if __name__ == "__main__":
    main()
