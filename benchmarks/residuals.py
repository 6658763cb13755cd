"""Where a tracked model misses or overshoots the masks, along the body: a diagnostic for the
shape fit on the mocap renders (docs/shape_fit.md).

    python benchmarks/residuals.py RUN_DIR [RUN_DIR ...] [--every 3] [--json FILE]

RUN_DIR is an ``ipf-jax track`` output of a ``mocap_walk_render`` set (``benchmarks/accuracy.py``
writes them under ``DIR/runs/SET[@seedK]``; the set is the folder's name before ``@``). Every
``--every``-th tracked frame is drawn with the run's body (``shape.json``) and pose (``poses.csv``)
into each camera at the masks' size (the likelihood's own pixel rule,
:func:`ipf_jax.likelihood.model_mask.model_mask`) and compared with the mask: *missed* pixels are
in the mask and not in the model, *extra* ones in the model and not in the mask. Each such pixel is
placed along the body by projecting it onto the image line from the ground truth's mid-ankle (0) to
its mid-hip (1), in that camera and frame; the shares of the masks' pixels per band of 0.2 are
printed (per mille). Ground truth only places the bands: the model is the run's.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from ipf_jax.paths import shared_data_dir

BANDS = np.round(np.arange(-0.4, 2.41, 0.2), 1)


def residuals(run: Path, every: int) -> dict:
    from ipf_jax.body.shape import load_shape
    from ipf_jax.data.dataset import open_dataset
    from ipf_jax.data.runfiles import read_joints_csv, read_pose_rows
    from ipf_jax.geometry.host import project_capsules, project_points
    from ipf_jax.geometry.world import up_rotation
    from ipf_jax.likelihood.model_mask import model_mask

    meta = json.loads((run / "run.json").read_text())
    name = run.name.split("@")[0]
    data = shared_data_dir() / "mocap_walk_render" / name
    ds = open_dataset(data)
    shape = load_shape(run / "shape.json")
    up = up_rotation(meta["up_axis"])
    poses = read_pose_rows(run / "poses.csv")
    truth = read_joints_csv(data / "ground_truth.csv")
    col = {n: i for i, n in enumerate(truth.names)}
    missed, extra = np.zeros(len(BANDS) - 1), np.zeros(len(BANDS) - 1)
    mask_px = 0
    for t in range(0, min(len(poses), len(truth.points)), every):
        p = truth.points[t]
        ankle = (p[col["left_ankle"]] + p[col["right_ankle"]]) / 2
        hip = (p[col["left_hip"]] + p[col["right_hip"]]) / 2
        if not (np.all(np.isfinite(poses[t])) and np.all(np.isfinite(ankle)) and np.all(np.isfinite(hip))):
            continue
        for cam, mask in zip(ds.cameras, ds.masks(t)):
            m = np.asarray(mask, bool)
            model = model_mask(project_capsules(poses[t], shape.values, up, [cam])[0], cam.height, cam.width)
            a, h = (project_points(cam, x)[0] for x in (ankle, hip))
            axis = h - a
            for sel, acc in ((m & ~model, missed), (model & ~m, extra)):
                ys, xs = np.nonzero(sel)
                s = ((xs - a[0]) * axis[0] + (ys - a[1]) * axis[1]) / float(axis @ axis)
                acc += np.histogram(np.clip(s, BANDS[0], BANDS[-1] - 1e-9), BANDS)[0]
            mask_px += int(m.sum())
    per_mille = lambda v: [round(1000 * float(x) / max(mask_px, 1), 2) for x in v]
    return {"run": str(run), "set": name, "mask_pixels": mask_px, "bands": BANDS.tolist(),
            "missed_per_mille": per_mille(missed), "extra_per_mille": per_mille(extra),
            "missed_total_per_mille": round(1000 * float(missed.sum()) / max(mask_px, 1), 2),
            "extra_total_per_mille": round(1000 * float(extra.sum()) / max(mask_px, 1), 2)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="+", type=Path)
    ap.add_argument("--every", type=int, default=3, help="every N-th tracked frame (default 3)")
    ap.add_argument("--json", type=Path, help="write the figures here")
    args = ap.parse_args(argv)
    if args.every < 1:
        sys.exit("error: --every must be >= 1")
    out = []
    print("band (0 = mid-ankle, 1 = mid-hip): " + " ".join(f"{b:5.1f}" for b in BANDS[:-1])
          + "  (the ends hold everything beyond)")
    for run in args.runs:
        if not (run / "poses.csv").is_file() or not (run / "shape.json").is_file():
            sys.exit(f"error: {run}: not a tracked run (poses.csv and shape.json needed)")
        r = residuals(run, args.every)
        out.append(r)
        print(f"{r['set']}: missed {r['missed_total_per_mille']:.1f}, extra {r['extra_total_per_mille']:.1f} "
              f"per mille of {r['mask_pixels']} mask pixels")
        print("  missed " + " ".join(f"{x:5.1f}" for x in r["missed_per_mille"]))
        print("  extra  " + " ".join(f"{x:5.1f}" for x in r["extra_per_mille"]))
    if args.json:
        args.json.write_text(json.dumps(out, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
