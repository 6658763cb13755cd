"""The shape fit's own frames against the ground truth: were their poses right?

    python benchmarks/fit_frames.py RUN_DIR_OR_ACCURACY_OUT... [--csv FILE]

The shape fit (``ipf-jax track --shape-frames K``, docs/shape_fit.md) fits the body with the
poses of K frames, each found by a light initialisation of its own. A frame whose pose is wrong
(the legs the wrong way round, an arm elsewhere) pulls the body towards whatever fits that pose.
For every run (a run folder, or every run under an ``accuracy.py --out`` folder's ``runs/``)
whose ``run.json`` has ``shape_fit.frame_poses`` and whose data set has a ``ground_truth.csv``
(the ``mocap_walk_render`` sets), this prints, per fitted frame, the pose's weight with the
fitted body, its error over the 12 limb joints, the worst joint, whether the legs are the wrong
way round (the two ankles' error at least halved by exchanging them) and the hips' mean vertical
offset, then per run the frames whose 12-joint error is over 60 mm.
"""
from __future__ import annotations

import argparse
import csv
import json
import sys
from pathlib import Path

import numpy as np

from ipf_jax.body.model import LIMB_JOINTS, POINT_INDEX
from ipf_jax.body.shape import shape_from_json
from ipf_jax.data.runfiles import read_joints_csv
from ipf_jax.geometry.kinematics import forward_kinematics
from ipf_jax.geometry.world import up_rotation
from ipf_jax.paths import shared_data_dir

WRONG_MM = 60.0  # a frame whose 12-joint error is over this is counted as a wrong pose


def truth_points(gt_csv: Path) -> dict[int, dict[str, np.ndarray]]:
    """frame -> joint -> (3,) ground-truth position (m)."""
    table = read_joints_csv(gt_csv)
    cols = [table.names.index(j) for j in LIMB_JOINTS]
    return {int(f): dict(zip(LIMB_JOINTS, pts[cols])) for f, pts in zip(table.frame, table.points)}


def frame_rows(run_json: Path, data_root: Path) -> list[dict]:
    """One row per fitted frame of a run (empty when the run has no fit or no ground truth)."""
    doc = json.loads(run_json.read_text())
    fit = doc.get("shape_fit") or {}
    poses = fit.get("frame_poses")
    name = Path(str(doc.get("dataset") or "")).name or run_json.parent.name.split("@")[0]
    gt_csv = data_root / name / "ground_truth.csv"
    if not poses or not gt_csv.is_file():
        return []
    truth = truth_points(gt_csv)
    values = shape_from_json(doc["shape"]).values
    U = up_rotation(doc["up_axis"])
    rows = []
    for fp in poses:
        gt = truth.get(int(fp["frame"]))
        if gt is None:
            continue
        pts = forward_kinematics(np.asarray(fp["pose"], float), values, U, xp=np).points
        err = {j: 1000 * (pts[POINT_INDEX[j]] - gt[j]) for j in LIMB_JOINTS}
        size = {j: float(np.linalg.norm(e)) for j, e in err.items()}
        ankles = size["left_ankle"] + size["right_ankle"]
        crossed = (np.linalg.norm(1000 * pts[POINT_INDEX["left_ankle"]] - 1000 * gt["right_ankle"])
                   + np.linalg.norm(1000 * pts[POINT_INDEX["right_ankle"]] - 1000 * gt["left_ankle"]))
        hips_up = float(np.mean([err[j] @ U[:, 2] for j in ("left_hip", "right_hip")]))
        worst = max(size, key=size.get)
        rows.append({"run": run_json.parent.name, "frame": int(fp["frame"]), "weight": fp["weight"],
                     "mpjpe_mm": round(float(np.mean(list(size.values()))), 1),
                     "worst_joint": worst, "worst_mm": round(size[worst], 1),
                     "legs_swapped": bool(crossed <= 0.5 * ankles),
                     "hips_up_mm": round(hips_up, 1)})
    return rows


def run_files(paths: list[str]) -> list[Path]:
    out = []
    for p in map(Path, paths):
        if (p / "run.json").is_file():
            out.append(p / "run.json")
        else:
            out += sorted(p.glob("runs/*/run.json"))
    return out


def runs_from_args(argv, doc: str) -> tuple[list[Path], str | None]:
    """``RUN_DIR_OR_ACCURACY_OUT... [--csv FILE]`` -> (the run.json files, the CSV path); the
    files are empty (and said on stderr) when none is found."""
    ap = argparse.ArgumentParser(description=doc.split("\n\n")[0])
    ap.add_argument("paths", nargs="+", help="run folders or accuracy.py --out folders")
    ap.add_argument("--csv", help="also write every row here")
    args = ap.parse_args(argv)
    files = run_files(args.paths)
    if not files:
        print("error: no run.json under " + ", ".join(args.paths), file=sys.stderr)
    return files, args.csv


def write_rows(path: str | None, rows: list[dict]) -> None:
    """The rows as a CSV at ``path`` (nothing when no path or no rows)."""
    if path and rows:
        with open(path, "w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)


def main(argv=None) -> int:
    files, csv_path = runs_from_args(argv, __doc__)
    if not files:
        return 2
    root = shared_data_dir() / "mocap_walk_render"
    rows = []
    for f in files:
        got = frame_rows(f, root)
        if not got:
            print(f"{f.parent.name}: no fitted frames or no ground truth")
            continue
        rows += got
        print(f"{f.parent.name}")
        for r in got:
            flags = " legs swapped" if r["legs_swapped"] else ""
            print(f"  frame {r['frame']:4d}  weight {r['weight']}  12 joints {r['mpjpe_mm']:6.1f} mm  "
                  f"worst {r['worst_joint']} {r['worst_mm']:.0f}  hips up {r['hips_up_mm']:+.0f}{flags}")
        bad = [r["frame"] for r in got if r["mpjpe_mm"] > WRONG_MM]
        print(f"  {len(bad)} of {len(got)} frames over {WRONG_MM:.0f} mm: {bad}")
    if rows:
        n_bad = sum(r["mpjpe_mm"] > WRONG_MM for r in rows)
        print(f"\n{len(rows)} fitted frames, {n_bad} over {WRONG_MM:.0f} mm, "
              f"{sum(r['legs_swapped'] for r in rows)} with the legs swapped; "
              f"median 12-joint error {np.median([r['mpjpe_mm'] for r in rows]):.1f} mm")
    write_rows(csv_path, rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
