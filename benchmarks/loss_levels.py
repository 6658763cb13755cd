"""Calibrate the absolute loss test's levels (:mod:`ipf_jax.tracking.loss`) on finished runs.

    python benchmarks/loss_levels.py RUNS_DIR [--percentile 0.5] [--json FILE]

``RUNS_DIR`` holds one tracking run per visible render, named after its set (``accuracy.py``'s
``OUT/runs``). For every frame of every run the estimate (``poses.csv``, the run's ``shape.json``,
cameras at the run's scoring resolution) is scored again and its per-camera shares
``explained = Nc / (Nc + Ns)`` and ``covered = Nc / (Nc + Nm)`` taken in the camera where each is
lowest; the frame's mean 12-joint error against ``ground_truth.csv`` says whether it is well
tracked (< 100 mm) or lost (> 200 mm). Prints the shares' percentiles over both kinds of frame,
the levels the rule gives (``--percentile`` of the well-tracked frames, rounded down to 0.05) and
how many well-tracked and lost frames fall below them.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from ipf_jax.analysis.evaluation import evaluate_files
from ipf_jax.analysis.evaluation.metrics import frame_errors
from ipf_jax.body.shape import load_shape
from ipf_jax.data.dataset import open_dataset
from ipf_jax.data.runfiles import read_pose_rows, read_table
from ipf_jax.data.silhouette import resize_mask
from ipf_jax.geometry.world import up_rotation
from ipf_jax.likelihood.scorer import Scorer, make_observation, scoring_cameras
from ipf_jax.paths import shared_data_dir
from ipf_jax.tracking.loss import coverage

GOOD_M, LOST_M = 0.100, 0.200


def run_shares(run_dir: Path, root: Path) -> tuple[np.ndarray, np.ndarray]:
    """((F, 2) lowest (explained, covered) per frame, (F,) frame error m) of one run."""
    run = json.loads((run_dir / "run.json").read_text())
    ds = open_dataset(root / run_dir.name)
    cams, scales = scoring_cameras(ds.cameras, run["settings"]["resolution"])
    U = up_rotation(run["up_axis"])
    scorer = Scorer(cams, load_shape(run_dir / "shape.json"), U, chunk=8)  # one pose per call
    frames = read_table(run_dir / "poses.csv", "poses file")[1][:, 0].astype(int)
    ok = np.isfinite(read_table(run_dir / "poses.csv", "poses file")[1][:, 2:]).all(1)
    poses = read_pose_rows(run_dir / "poses.csv") if ok.all() else None
    if poses is None:
        raise SystemExit(f"{run_dir}: missing frames (nan rows); calibrate on complete runs")
    shares = []
    for f, q in zip(frames, poses):
        masks = [m if s == 1.0 else resize_mask(m, c.height, c.width)
                 for m, s, c in zip(ds.masks(int(f)), scales, cams)]
        obs = make_observation(masks)
        shares.append(coverage(scorer.counts(q[None], obs)[0], obs.active).lowest())
    ev, _, _ = evaluate_files(run_dir / "joints.csv", root / run_dir.name / "ground_truth.csv")
    return np.array(shares), frame_errors(ev)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("runs", type=Path, help="folder of runs named after their sets")
    ap.add_argument("--percentile", type=float, default=0.5, help="of the well-tracked frames")
    ap.add_argument("--json", type=Path, help="write every frame's shares and error here")
    args = ap.parse_args(argv)
    root = shared_data_dir() / "mocap_walk_render"
    per_set, all_s, all_e = {}, [], []
    for run_dir in sorted(p for p in args.runs.iterdir() if (p / "run.json").is_file()):
        s, e = run_shares(run_dir, root)
        per_set[run_dir.name] = {"shares": s.tolist(), "error_m": e.tolist()}
        all_s.append(s)
        all_e.append(e)
        print(f"{run_dir.name}: {len(e)} frames, {int((e < GOOD_M).sum())} good, "
              f"{int((e > LOST_M).sum())} lost; lowest explained {s[:, 0].min():.3f}, "
              f"covered {s[:, 1].min():.3f}", flush=True)
    s, e = np.concatenate(all_s), np.concatenate(all_e)
    good, lost = e < GOOD_M, e > LOST_M
    pct = (0.5, 1, 5, 25, 50)
    print("\n| share | frames | " + " | ".join(f"p{p:g}" for p in pct) + " |")
    print("|---|---|" + "---|" * len(pct))
    for k, name in enumerate(("explained", "covered")):
        for label, sel in (("good (<100 mm)", good), ("lost (>200 mm)", lost)):
            if sel.any():
                print(f"| {name} {label} | {int(sel.sum())} | "
                      + " | ".join(f"{np.percentile(s[sel, k], p):.3f}" for p in pct) + " |")
    if args.json:
        args.json.write_text(json.dumps({"sets": per_set}, indent=1))
    if not good.any():
        print("\nno well-tracked frames: no levels")
        return 0
    levels = [np.floor(np.percentile(s[good, k], args.percentile) / 0.05) * 0.05 for k in range(2)]
    below = (s[:, 0] < levels[0]) | (s[:, 1] < levels[1])
    print(f"\nlevels at p{args.percentile:g} of the good frames, rounded down to 0.05: explained "
          f"{levels[0]:.2f}, covered {levels[1]:.2f}; below them: {int((below & good).sum())} of "
          f"{int(good.sum())} good frames, {int((below & lost).sum())} of {int(lost.sum())} lost")
    if args.json:
        args.json.write_text(json.dumps({"levels": levels, "sets": per_set}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
