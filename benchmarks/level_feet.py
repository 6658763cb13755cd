"""Does the likelihood prefer the tracked feet on tiptoe to level ones where the truth has them?

    python benchmarks/level_feet.py RUN_DIR FRAMES   (e.g. 0,10,40,60,100)

For each frame of a run of a ``mocap_walk_render`` set: the tracked pose, and the same pose with
one leg or both moved so that its knee and ankle come nearest the ground truth's and its foot is
level (heel and toe points at the truth's ankle plus the run's own body's level offsets, along the
tracked foot's heading; the limb angles by the shape fit's Gauss-Newton,
``ipf_jax.geometry.retarget``, 8 steps). Every pose is scored with the run's body (320 px, the
tracker's scorer); prints the weights, the ankles' distance to the truth and each camera's counts.
``benchmarks/foot_stance.py`` measures how far the tracked feet stand on tiptoe.
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

from ipf_jax.body.limits import load_limits
from ipf_jax.body.model import POINT_INDEX
from ipf_jax.body.shape import load_shape
from ipf_jax.data.dataset import open_dataset
from ipf_jax.data.runfiles import read_joints_csv, read_pose_rows
from ipf_jax.data.silhouette import resize_mask
from ipf_jax.geometry.kinematics import forward_kinematics
from ipf_jax.geometry.retarget import KEPT_POINTS, limb_points, retarget
from ipf_jax.geometry.world import up_rotation
from ipf_jax.likelihood.scorer import Scorer, make_observation, scoring_cameras, weights_from_counts
from ipf_jax.paths import shared_data_dir


def _row(name: str) -> int:
    """The row of a joint in ``limb_points``' result."""
    return list(KEPT_POINTS).index(POINT_INDEX[name])


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if len(argv) != 2:
        print(__doc__.split("\n\n")[1].strip(), file=sys.stderr)
        return 2
    run, frames = Path(argv[0]), [int(x) for x in argv[1].split(",")]
    doc = json.loads((run / "run.json").read_text())
    U = up_rotation(doc["up_axis"])
    up = U[:, 2]
    name = Path(str(doc.get("dataset") or "")).name or run.name.split("@")[0]
    ds = open_dataset(shared_data_dir() / "mocap_walk_render" / name)
    shape = load_shape(run / "shape.json")
    v = shape.values
    truth = read_joints_csv(ds.path / "ground_truth.csv")
    t_row = {int(f): i for i, f in enumerate(truth.frame)}
    tracked = read_pose_rows(run / "poses.csv")
    p_row = {int(f): i for i, f in enumerate(read_joints_csv(run / "joints.csv").frame)}
    cams, scales = scoring_cameras(ds.cameras, 320)
    scorer, clip = Scorer(cams, shape, U), load_limits().clip
    for f in frames:
        q = tracked[p_row[f]]
        gt = {n: truth.points[t_row[f]][truth.names.index(n)] for n in truth.names}
        pts = forward_kinematics(q, v, U, xp=np).points
        kept = limb_points(q[None], v[None], U)[0]
        variants = {"tracked": q}
        for legs in (("left",), ("right",), ("left", "right")):
            t = kept.copy()
            for s in legs:
                a = gt[f"{s}_ankle"]
                head = pts[POINT_INDEX[f"{s}_toe"]] - pts[POINT_INDEX[f"{s}_heel"]]
                head -= (head @ up) * up
                head /= np.linalg.norm(head)
                at = {"knee": gt[f"{s}_knee"], "ankle": a,
                      "heel": a - shape["heel_back"] * head - shape["heel_down"] * up,
                      "toe": a + shape["toe_forward"] * head - shape["toe_down"] * up}
                for j, x in at.items():
                    t[_row(f"{s}_{j}")] = x
            variants[" + ".join(legs) + " level"] = retarget(q[None], v[None], t[None], U, clip,
                                                              iterations=8)[0]
        masks = [m if s == 1.0 else resize_mask(m, c.height, c.width)
                 for m, s, c in zip(ds.masks(f), scales, cams)]
        obs = make_observation(masks)
        counts = scorer.counts(np.stack(list(variants.values())), obs)
        w, _ = weights_from_counts(counts, obs.active)
        print(f"frame {f}")
        for (k, qq), wi, c in zip(variants.items(), w, counts):
            P = forward_kinematics(qq, v, U, xp=np).points
            err = [1000 * np.linalg.norm(P[POINT_INDEX[f"{s}_ankle"]] - gt[f"{s}_ankle"])
                   for s in ("left", "right")]
            cells = " ".join(f"{c[j, 0]}/{c[j, 1]}/{c[j, 2]}" for j in range(len(cams)))
            print(f"  {k:22s} w {wi:.4f}  ankles {err[0]:3.0f} / {err[1]:3.0f} mm from the truth  "
                  f"Nc/Ns/Nm per camera {cells}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
