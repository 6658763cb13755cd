"""Two or more ``benchmarks/accuracy.py`` results side by side: per set and per joint.

    python benchmarks/accuracy_compare.py LABEL=DIR [LABEL=DIR ...] [--out FILE.md]

For each result (``DIR/accuracy.json``) and every set they share: MPJPE, the error left once each
joint's constant offset is removed (offset-free) and the mean offset; then, per joint, the
offset-free error and the offset averaged over the shared sets. Prints markdown (and writes it to
``--out``).
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np


def load(spec: str) -> tuple[str, dict]:
    label, _, folder = spec.partition("=")
    rows = json.loads((Path(folder) / "accuracy.json").read_text())["rows"]
    return label, {r["set"]: r for r in rows}


def tables(results: list[tuple[str, dict]]) -> str:
    sets = [s for s in results[0][1] if all(s in r for _, r in results)]
    cols = [(lab, key) for lab, _ in results for key in ("mpjpe_mm", "offset_free_mm", "mean_offset_mm")]
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
