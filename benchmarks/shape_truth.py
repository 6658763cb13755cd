"""Segment lengths of the ground-truth joints of every visible render against a run's shape.

    python benchmarks/shape_truth.py [--runs DIR] [--sets walks4clean]

For each set: thigh, shank, hip spacing, shoulder width, upper arm and forearm of
``ground_truth.csv`` (mean over frames, left and right averaged), and, with ``--runs DIR``, the
same lengths of the shape each run found (``DIR/runs/SET/run.json``, or the first ``SET@seedN``, -> ``shape``), and their
difference. Prints a markdown table.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from ipf_jax.paths import shared_data_dir

sys.path.insert(0, str(Path(__file__).parent))
from accuracy import set_names

LENGTHS = ("thigh", "shank", "hip_spacing", "shoulder_width", "upper_arm", "forearm")


def truth_lengths(gt_csv: Path) -> dict[str, float]:
    """Mean segment lengths (m) of a ground-truth file, left and right averaged."""
    with open(gt_csv) as fh:
        header = fh.readline().strip().split(",")
    data = np.genfromtxt(gt_csv, delimiter=",", skip_header=1, ndmin=2)

    def p(name):
        i = header.index(f"{name}_x")
        return data[:, i:i + 3]

    def d(a, b):
        return float(np.nanmean(np.linalg.norm(p(a) - p(b), axis=1)))

    side = lambda a, b: 0.5 * (d(f"left_{a}", f"left_{b}") + d(f"right_{a}", f"right_{b}"))
    return {"thigh": side("hip", "knee"), "shank": side("knee", "ankle"),
            "hip_spacing": d("left_hip", "right_hip"),
            "shoulder_width": d("left_shoulder", "right_shoulder"),
            "upper_arm": side("shoulder", "elbow"), "forearm": side("elbow", "wrist")}


def shape_lengths(params: dict) -> dict[str, float]:
    """The same lengths of a shape file's ``params``."""
    return {"thigh": params["thigh"], "shank": params["shank"],
            "hip_spacing": 2 * params["hip_half_width"],
            "shoulder_width": 2 * params["shoulder_half_width"],
            "upper_arm": params["upper_arm"], "forearm": params["forearm"]}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", help="an accuracy.py --out folder")
    ap.add_argument("--sets", default="walks4clean")
    args = ap.parse_args(argv)
    root = shared_data_dir() / "mocap_walk_render"
    rows = []
    for name in set_names(args.sets, root):
        truth = truth_lengths(root / name / "ground_truth.csv")
        row = {"set": name, "truth_mm": {k: 1000 * v for k, v in truth.items()}}
        runs = Path(args.runs or "") / "runs"
        # one seed: runs/SET; several (--seeds): runs/SET@seedN, of which the first is read
        run = next((p for p in [runs / name / "run.json", *sorted(runs.glob(f"{name}@seed*/run.json"))]
                    if p.is_file()), runs / name / "run.json")
        if args.runs and run.is_file():
            doc = json.loads(run.read_text())
            found = shape_lengths(doc["shape"]["params"])
            row["found_mm"] = {k: 1000 * v for k, v in found.items()}
            row["height_m"] = doc.get("height_m")
        rows.append(row)
    head = "| set | " + " | ".join(LENGTHS) + " |"
    print(head + "\n|" + "---|" * (len(LENGTHS) + 1))
    for r in rows:
        cells = []
        for k in LENGTHS:
            t = r["truth_mm"][k]
            if "found_mm" in r:
                f = r["found_mm"][k]
                cells.append(f"{f:.0f} / {t:.0f} ({f - t:+.0f})")
            else:
                cells.append(f"{t:.0f}")
        print(f"| {r['set']} | " + " | ".join(cells) + " |")
    if any("found_mm" in r for r in rows):
        print("\n(found / truth (found - truth), mm)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
