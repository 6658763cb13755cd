"""The tracked feet while the ground truth's foot stands flat: level, or on tiptoe?

    python benchmarks/foot_stance.py RUN_DIR_OR_ACCURACY_OUT... [--csv FILE]

For every run (a run folder, or every run under an ``accuracy.py --out`` folder's ``runs/``) of a
data set with a ``ground_truth.csv`` (the ``mocap_walk_render`` sets), and for each side, the
frames where the truth's ankle is within :data:`FLAT_MM` of its lowest over the recording (the
foot flat on the floor: stance in a walk, the whole recording while seated), and over them:

* ``ankle_up_mm``: the tracked ankle's mean height above the truth's;
* ``heel_up_mm``: how much higher the tracked heel point stands over the toe point than the
  run's own body has it with the foot level (``toe_down - heel_down`` of ``run.json``'s shape):
  0 for a level foot, positive on tiptoe (toes down, heel up);
* ``pitch_deg``: the same as an angle over the heel-to-toe distance;
* ``lowest_mm``: the median height over the floor of the tracked body's lowest capsule point
  (``poses.csv`` with the run's body; negative: sunk into the floor), or None without
  ``poses.csv``.

The joints are ``joints.csv``'s; ``run.json`` gives the up axis and the body.
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

from ipf_jax.body.shape import shape_from_json
from ipf_jax.data.runfiles import read_joints_csv, read_pose_rows
from ipf_jax.geometry.world import up_rotation
from ipf_jax.paths import shared_data_dir
from ipf_jax.tracking.shape_fit import lowest_heights

sys.path.insert(0, str(Path(__file__).parent))
from fit_frames import runs_from_args, write_rows  # noqa: E402

FLAT_MM = 15.0  # a truth ankle within this of its lowest: the foot is taken to stand flat


def side_rows(run_json: Path, data_root: Path) -> list[dict]:
    """One row per side of a run (empty when the run's data set has no ground truth)."""
    run = run_json.parent
    doc = json.loads(run_json.read_text())
    name = Path(str(doc.get("dataset") or "")).name or run.name.split("@")[0]
    gt_csv = data_root / name / "ground_truth.csv"
    if not gt_csv.is_file() or not (run / "joints.csv").is_file():
        return []
    up = up_rotation(doc["up_axis"])[:, 2]
    body = shape_from_json(doc["shape"])
    level = 1000 * (body["toe_down"] - body["heel_down"])  # heel over toe, the foot level
    truth, tracked = read_joints_csv(gt_csv), read_joints_csv(run / "joints.csv")
    t_index = {int(f): i for i, f in enumerate(truth.frame)}
    both = [(i, t_index[int(f)]) for i, f in enumerate(tracked.frame) if int(f) in t_index]
    lowest = None
    if (run / "poses.csv").is_file():
        q = read_pose_rows(run / "poses.csv")  # a row per joints.csv row, in its order
        if len(q) == len(tracked.frame):
            lowest = 1000 * lowest_heights(q, np.broadcast_to(body.values, (len(q), len(body.values))),
                                           up_rotation(doc["up_axis"]))
    rows = []
    for side in ("left", "right"):
        a_truth = np.array([1000 * truth.points[j][truth.names.index(f"{side}_ankle")] @ up for _, j in both])
        flat = a_truth <= a_truth.min() + FLAT_MM

        def point(name, i):
            return 1000 * tracked.points[i][tracked.names.index(f"{side}_{name}")]

        ankle_up, heel_up, pitch, low = [], [], [], []
        for (i, _), at, is_flat in zip(both, a_truth, flat):
            heel, toe, ankle = point("heel", i), point("toe", i), point("ankle", i)
            if not is_flat or not np.all(np.isfinite(ankle)):
                continue
            ankle_up.append(ankle @ up - at)
            if lowest is not None:
                low.append(lowest[i])
            rise = (heel - toe) @ up - level
            heel_up.append(rise)
            pitch.append(np.degrees(np.arcsin(np.clip(rise / np.linalg.norm(heel - toe), -1, 1))))
        rows.append({"run": run.name, "side": side, "flat_frames": len(ankle_up),
                     "ankle_up_mm": round(float(np.mean(ankle_up)), 1) if ankle_up else None,
                     "heel_up_mm": round(float(np.mean(heel_up)), 1) if heel_up else None,
                     "pitch_deg": round(float(np.mean(pitch)), 1) if pitch else None,
                     "lowest_mm": round(float(np.median(low)), 1) if low else None})
    return rows


def main(argv=None) -> int:
    files, csv_path = runs_from_args(argv, __doc__)
    if not files:
        return 2
    rows = []
    print(f"{'run':40s} {'side':5s} {'frames':>6s} {'ankle up':>9s} {'heel up':>8s} {'pitch':>6s} "
          f"{'lowest':>7s}")
    for f in files:
        got = side_rows(f, shared_data_dir() / "mocap_walk_render")
        rows += got
        for r in got:
            if r["flat_frames"]:
                print(f"{r['run']:40s} {r['side']:5s} {r['flat_frames']:6d} {r['ankle_up_mm']:+8.1f}  "
                      f"{r['heel_up_mm']:+7.1f} {r['pitch_deg']:+6.1f} "
                      + (f"{r['lowest_mm']:+7.1f}" if r["lowest_mm"] is not None else "      -"))
    done = [r for r in rows if r["flat_frames"]]
    if done:
        print(f"\n{len(done)} feet: ankle {np.mean([r['ankle_up_mm'] for r in done]):+.1f} mm, heel over "
              f"toe {np.mean([r['heel_up_mm'] for r in done]):+.1f} mm "
              f"({np.mean([r['pitch_deg'] for r in done]):+.1f} deg) against the truth's flat feet")
        low = [r["lowest_mm"] for r in done if r["lowest_mm"] is not None]
        if low:
            print(f"the body's lowest point over the floor in those frames: median {np.median(low):+.1f} mm "
                  f"({len(low)} feet)")
    write_rows(csv_path, rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
