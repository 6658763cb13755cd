"""Two or more ``benchmarks/accuracy.py`` results side by side: per set and per joint.

    python benchmarks/accuracy_compare.py LABEL=DIR [LABEL=DIR ...] [--out FILE.md]

For each result (``DIR/accuracy.json``, or the path of such a file) and every set they share: MPJPE,
the error left once each joint's constant offset is removed (offset-free), the mean offset and the
hip/knee/ankle offset; then, per joint, the offset-free error and the offset averaged over the
shared sets. A result with several seeds per set (``accuracy.py --seeds``) counts each set's mean
over its seeds. Prints markdown (and writes it to ``--out``).
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np


KEYS = ("mpjpe_mm", "offset_free_mm", "mean_offset_mm", "leg_offset_mm")


def load(spec: str) -> tuple[str, dict]:
    label, _, where = spec.partition("=")
    path = Path(where)
    rows = json.loads((path if path.suffix == ".json" else path / "accuracy.json").read_text())["rows"]
    by_set: dict[str, list[dict]] = {}
    for r in rows:
        if "error" not in r:  # a set that failed to run has no figures (accuracy.py says why)
            by_set.setdefault(r["set"], []).append(r)
    return label, {s: seed_mean(rs) for s, rs in by_set.items()}


def seed_mean(rows: list[dict]) -> dict:
    """One set's rows (one per seed) -> a row of their means, per joint too (the figures these
    tables use; ``accuracy.over_seeds`` gives the spread of the headline columns instead)."""
    joints = rows[0]["per_joint"]
    return {**{k: float(np.mean([r[k] for r in rows])) for k in KEYS}, "seeds": len(rows),
            "per_joint": {j: {k: float(np.mean([r["per_joint"][j][k] for r in rows]))
                              for k in ("offset_free_m", "offset_m")} for j in joints}}


def tables(results: list[tuple[str, dict]]) -> str:
    sets = [s for s in results[0][1] if all(s in r for _, r in results)]
    cols = [(lab, key) for lab, _ in results for key in KEYS]
    head = "| set | " + " | ".join(f"{lab} {k.replace('_mm', '').replace('_', ' ')}" for lab, k in cols) + " |"
    md = [head, "|---|" + "---|" * len(cols)]
    for s in sets:
        md.append(f"| {s} | " + " | ".join(f"{dict(results)[lab][s][k]:.1f}" for lab, k in cols) + " |")
    md.append("| **mean** | " + " | ".join(
        f"**{np.mean([dict(results)[lab][s][k] for s in sets]):.1f}**" for lab, k in cols) + " |")
    joints = list(results[0][1][sets[0]]["per_joint"])
    md += ["", f"Per joint, mean over the {len(sets)} sets (mm): offset-free / constant offset", "",
           "| joint | " + " | ".join(lab for lab, _ in results) + " |", "|---|" + "---|" * len(results)]
    for j in joints:
        cells = []
        for lab, res in results:
            free = np.mean([res[s]["per_joint"][j]["offset_free_m"] for s in sets]) * 1000
            off = np.mean([res[s]["per_joint"][j]["offset_m"] for s in sets]) * 1000
            cells.append(f"{free:.1f} / {off:.1f}")
        md.append(f"| {j} | " + " | ".join(cells) + " |")
    return "\n".join(md) + "\n"


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("results", nargs="+", help="LABEL=DIR of an accuracy.py run")
    p.add_argument("--out", type=Path)
    a = p.parse_args(argv)
    text = tables([load(s) for s in a.results])
    if a.out:
        a.out.write_text(text)
    print(text)


if __name__ == "__main__":
    main()
