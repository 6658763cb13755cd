"""The tracked pelvis's sideways tilt against the ground truth's, per run of an accuracy folder.

    python benchmarks/pelvis_tilt.py --runs DIR

For every run in ``DIR/runs`` (``SET`` or ``SET@seedN``, from ``benchmarks/accuracy.py --out DIR``):
the tilt of the line from the left to the right hip joint against the floor (degrees, positive:
the right hip higher; the run's up axis from its ``run.json``), for the tracked joints and for
``ground_truth.csv``; their difference split into its mean over the frames (the constant offset)
and the standard deviation of what is left. Prints a markdown table, the mean absolute offset, the
mean of what is left and how many runs are off by more than 5 deg. Silhouettes barely see
this tilt (:mod:`ipf_jax.tracking.prior`).
"""
from __future__ import annotations

import argparse
import json
from collections import defaultdict
from pathlib import Path

import numpy as np

from ipf_jax.data.runfiles import JointsTable, read_joints_csv
from ipf_jax.geometry.world import up_rotation
from ipf_jax.paths import shared_data_dir


def hips(table: JointsTable) -> tuple[np.ndarray, np.ndarray]:
    """(T, 3) left and right hip joints of a joints table."""
    return (table.points[:, table.names.index("left_hip")],
            table.points[:, table.names.index("right_hip")])


def tilt_deg(left: np.ndarray, right: np.ndarray, up: np.ndarray) -> np.ndarray:
    """(T,) angle of left -> right against the plane normal to ``up``, degrees."""
    d = right - left
    return np.degrees(np.arcsin(np.clip(d @ up / np.linalg.norm(d, axis=1), -1, 1)))


def run_error(run_dir: Path, data_root: Path) -> tuple[float, float]:
    """The tracked tilt minus the truth's, degrees: (mean over the frames, SD of the rest)."""
    run = json.loads((run_dir / "run.json").read_text())
    up = up_rotation(run["up_axis"])[:, 2]  # the world's up direction
    name = run_dir.name.split("@")[0]
    est = read_joints_csv(run_dir / "joints.csv")
    truth = read_joints_csv(data_root / name / "ground_truth.csv")
    _, i, j = np.intersect1d(est.frame, truth.frame, return_indices=True)  # the same frames
    e = tilt_deg(*hips(est), up)[i] - tilt_deg(*hips(truth), up)[j]
    return float(np.nanmean(e)), float(np.nanstd(e))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", required=True, help="an accuracy.py --out folder")
    args = ap.parse_args(argv)
    data_root = shared_data_dir() / "mocap_walk_render"
    by_set: dict[str, list[tuple[float, float]]] = defaultdict(list)
    for run_dir in sorted(Path(args.runs, "runs").iterdir()):
        if (run_dir / "joints.csv").is_file():
            by_set[run_dir.name.split("@")[0]].append(run_error(run_dir, data_root))
    print("| set | pelvis tilt error per run, deg (tracked - truth): constant offset / SD of the rest |")
    print("|---|---|")
    for name, errs in by_set.items():
        print(f"| {name} | " + ", ".join(f"{m:+.1f} / {sd:.1f}" for m, sd in errs) + " |")
    every = np.array([e for errs in by_set.values() for e in errs])
    print(f"\nmean |offset| {np.mean(np.abs(every[:, 0])):.2f} deg, mean SD of the rest "
          f"{np.mean(every[:, 1]):.2f} deg over {len(every)} runs; "
          f"{int(np.sum(np.abs(every[:, 0]) > 5))} offsets over 5 deg")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
