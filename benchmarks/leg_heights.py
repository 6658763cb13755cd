"""Where the hips' vertical offset comes from: the ankle's height, the shank's and the thigh's.

    python benchmarks/leg_heights.py RUN_DIR_OR_ACCURACY_OUT... [--csv FILE]

For every run of a data set with a ``ground_truth.csv`` (the ``mocap_walk_render`` sets), the
tracked hip's mean height over the truth's (``hip_mm``, mean of the two sides over every scored
frame) splits exactly into three terms:

* ``ankle_mm``: the tracked ankle's mean height over the truth's;
* ``shank_mm``: the tracked knee-over-ankle height minus the truth's (the shank's vertical extent);
* ``thigh_mm``: the tracked hip-over-knee height minus the truth's;

and beside them the segments' mean lengths against the truth's (``thigh_len_mm``, ``shank_len_mm``;
a tracked body's segments are fixed, the truth's joints vary by a few mm). Where ``thigh_mm``
follows ``thigh_len_mm`` the thigh's vertical error is its fitted length's, not the knee's angle.
The last lines give, over the runs, the correlation of each height term with its length error
and how much of the hips' offsets the lengths alone explain.
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

from ipf_jax.data.runfiles import read_joints_csv
from ipf_jax.geometry.world import up_rotation
from ipf_jax.paths import shared_data_dir

sys.path.insert(0, str(Path(__file__).parent))
from fit_frames import runs_from_args, write_rows  # noqa: E402

TERMS = ("ankle_mm", "shank_mm", "thigh_mm", "hip_mm", "thigh_len_mm", "shank_len_mm")


def run_row(run_json: Path, data_root: Path) -> dict | None:
    """The terms of one run, the two sides averaged (None without a ground truth)."""
    run = run_json.parent
    doc = json.loads(run_json.read_text())
    name = Path(str(doc.get("dataset") or "")).name or run.name.split("@")[0]
    gt_csv = data_root / name / "ground_truth.csv"
    if not gt_csv.is_file() or not (run / "joints.csv").is_file():
        return None
    up = up_rotation(doc["up_axis"])[:, 2]
    truth, tracked = read_joints_csv(gt_csv), read_joints_csv(run / "joints.csv")
    t_index = {int(f): i for i, f in enumerate(truth.frame)}
    pairs = [(i, t_index[int(f)]) for i, f in enumerate(tracked.frame)
             if int(f) in t_index and np.all(np.isfinite(tracked.points[i]))]
    if not pairs:
        return None
    mine = (np.array([tracked.points[i] for i, _ in pairs]), tracked.names)
    theirs = (np.array([truth.points[j] for _, j in pairs]), truth.names)

    def terms(side):
        def at(table, joint):
            points, names = table
            return 1000 * points[:, names.index(f"{side}_{joint}")]

        height = {j: (at(mine, j) - at(theirs, j)) @ up for j in ("ankle", "knee", "hip")}

        def length(points, a, b):
            return np.linalg.norm(at(points, a) - at(points, b), axis=1).mean()

        return [height["ankle"].mean(), (height["knee"] - height["ankle"]).mean(),
                (height["hip"] - height["knee"]).mean(), height["hip"].mean(),
                length(mine, "hip", "knee") - length(theirs, "hip", "knee"),
                length(mine, "knee", "ankle") - length(theirs, "knee", "ankle")]

    mean = np.mean([terms("left"), terms("right")], axis=0)
    return {"run": run.name, **{k: round(float(v), 1) for k, v in zip(TERMS, mean)}}


def summary(rows: list[dict]) -> list[str]:
    """Correlations of the height terms with the length errors, and the hips explained by them."""
    a = {k: np.array([r[k] for r in rows]) for k in TERMS}
    lines = [f"{len(rows)} runs: mean |hip| {np.abs(a['hip_mm']).mean():.1f} mm = |ankle| "
             f"{np.abs(a['ankle_mm']).mean():.1f}, |shank| {np.abs(a['shank_mm']).mean():.1f}, |thigh| "
             f"{np.abs(a['thigh_mm']).mean():.1f} (means of the terms {a['ankle_mm'].mean():+.1f}, "
             f"{a['shank_mm'].mean():+.1f}, {a['thigh_mm'].mean():+.1f})"]
    if len(rows) > 2:
        for seg in ("thigh", "shank"):
            r = np.corrcoef(a[f"{seg}_mm"], a[f"{seg}_len_mm"])[0, 1]
            left = a[f"{seg}_mm"] - a[f"{seg}_len_mm"]
            lines.append(f"{seg}: height term against length error r = {r:.2f}; what the length leaves "
                         f"{np.abs(left).mean():.1f} mm on the mean (mean {left.mean():+.1f})")
        rest = a["hip_mm"] - a["thigh_len_mm"] - a["shank_len_mm"]
        lines.append(f"hips: {np.abs(a['hip_mm']).mean():.1f} mm on the mean; less the two length errors "
                     f"{np.abs(rest).mean():.1f} (mean {rest.mean():+.1f})")
    return lines


def main(argv=None) -> int:
    files, csv_path = runs_from_args(argv, __doc__)
    if not files:
        return 2
    rows = [r for f in files if (r := run_row(f, shared_data_dir() / "mocap_walk_render")) is not None]
    print(f"{'run':40s} " + " ".join(f"{k[:-3]:>10s}" for k in TERMS))
    for r in rows:
        print(f"{r['run']:40s} " + " ".join(f"{r[k]:+10.1f}" for k in TERMS))
    if rows:
        print("\n" + "\n".join(summary(rows)))
    write_rows(csv_path, rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
