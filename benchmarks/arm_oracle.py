"""Is a wrong arm the likelihood's or the search's? Tracked arms against the truth's, weighed.

    python benchmarks/arm_oracle.py RUN_DIR... [--min-error 120] [--every 1] [--frames 0,5]
                                    [--json FILE]

Each ``RUN_DIR`` is an ``ipf-jax track`` run of a ``mocap_walk_render`` set (``runs/SET@seedS``
of ``benchmarks/accuracy.py``). For each arm and each frame where its tracked wrist is more than
``--min-error`` mm from the ground truth's (every ``--every``-th such frame; or the ``--frames``
given), three poses are weighed on the frame's masks, all the tracked pose but for that arm's four
DOFs (shoulder flexion, abduction, rotation, elbow flexion):

* ``tracked``: the run's pose;
* ``truth``: the arm's DOFs solved so that its elbow and wrist come nearest the truth's (the
  limb solve of :func:`ipf_jax.geometry.retarget.hold` from six starts, inside the limits): what
  the likelihood says of the right arm;
* ``reach``: the best pose of :func:`ipf_jax.filters.reach.search` from the tracked pose (what the
  factored filter's reach search would find there).

A frame is the likelihood's failure when the truth's arm does not beat the tracked one by the
reach search's margin (:data:`ipf_jax.filters.reach.MARGIN`), the search's when it does; the
search finds it when its best beats the tracked pose by the margin too (its wrist error printed).
The weights are the tracker's with two cameras or more (the likelihood at the run's scoring
size; the one-camera lean prior is left out).
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from ipf_jax.body.limits import load_limits
from ipf_jax.body.model import POINT_INDEX
from ipf_jax.body.shape import load_shape
from ipf_jax.data.dataset import open_dataset
from ipf_jax.data.runfiles import read_joints_csv, read_pose_rows
from ipf_jax.data.silhouette import resize_mask
from ipf_jax.filters import reach
from ipf_jax.geometry.kinematics import forward_kinematics
from ipf_jax.geometry.retarget import KEPT_POINTS, hold, limb_points
from ipf_jax.geometry.world import up_rotation
from ipf_jax.likelihood.scorer import Scorer, make_observation, scoring_cameras, weights_from_counts

SIDES = ("left", "right")
#: Starts of the arm's solve onto the truth (the tracked arm and random ones)
STARTS = 6


class Run:
    """One run's body, poses, truth and scorer."""

    def __init__(self, run_dir: Path):
        doc = json.loads((run_dir / "run.json").read_text())
        self.name = run_dir.name
        self.up = up_rotation(doc["up_axis"])
        self.ds = open_dataset(Path(doc["dataset"]))
        self.shape = load_shape(run_dir / "shape.json").values
        joints = read_joints_csv(run_dir / "joints.csv")
        self.frames = [int(f) for f in joints.frame]
        self.poses = dict(zip(self.frames, np.asarray(read_pose_rows(run_dir / "poses.csv"), float)))
        truth = read_joints_csv(self.ds.path / "ground_truth.csv")
        self.truth = {int(f): truth.points[i] for i, f in enumerate(truth.frame)}
        self.truth_names = truth.names
        self.cams, self.scales = scoring_cameras(self.ds.cameras, doc["settings"]["resolution"])
        self.scorer = Scorer(self.cams, load_shape(run_dir / "shape.json"), self.up)
        lim = load_limits(doc["limits"]["name"])
        self.clip = lim.clip

    def points(self, q: np.ndarray) -> np.ndarray:
        return forward_kinematics(q, self.shape, self.up, xp=np).points

    def true_point(self, frame: int, name: str) -> np.ndarray:
        return np.asarray(self.truth[frame][self.truth_names.index(name)], float)

    def wrist_error_mm(self, q: np.ndarray, frame: int, side: str) -> float:
        j = f"{side}_wrist"
        return float(1000 * np.linalg.norm(self.points(q)[POINT_INDEX[j]] - self.true_point(frame, j)))

    def measure_on(self, frame: int):
        masks = [m if s == 1.0 else resize_mask(m, c.height, c.width)
                 for m, s, c in zip(self.ds.masks(frame), self.scales, self.cams)]
        obs = make_observation(masks)
        return lambda q: weights_from_counts(self.scorer.counts(np.asarray(q), obs), obs.active)[0]

    def truth_arm(self, q0: np.ndarray, frame: int, side: str) -> np.ndarray:
        """``q0`` with the arm's DOFs solved onto the truth's elbow and wrist
        (:func:`ipf_jax.geometry.retarget.hold` from the tracked arm and five random ones; the
        start nearest the truth kept: from a straight elbow the shoulder's rotation moves nothing)."""
        joints = [f"{side}_{j}" for j in ("elbow", "wrist")]
        which = np.array([list(KEPT_POINTS).index(POINT_INDEX[j]) for j in joints])
        goal = np.stack([self.true_point(frame, j) for j in joints])
        starts = np.repeat(q0[None], STARTS, axis=0)
        noise = np.random.default_rng(0).normal(0, 0.8, (STARTS - 1, 4))
        starts[1:, list(reach.ARMS[SIDES.index(side)])] += noise
        fits = hold(self.clip(starts), np.broadcast_to(self.shape, (STARTS, len(self.shape))),
                    np.broadcast_to(goal, (STARTS, 2, 3)), self.up, self.clip, which=which,
                    iterations=40)
        miss = ((limb_points(fits, self.shape, self.up, which=which) - goal) ** 2).sum((1, 2))
        return fits[np.argmin(miss)]


def probe(run: Run, frame: int, side: str) -> dict:
    q0 = run.poses[frame]
    measure = run.measure_on(frame)
    qt = run.truth_arm(q0, frame, side)
    w0, wt = measure(np.stack([q0, qt]))
    particles, weights = reach.search(q0, SIDES.index(side), measure, run.clip)
    k = int(np.argmax(weights))
    return {"run": run.name, "frame": frame, "side": side,
            "tracked": [float(w0), run.wrist_error_mm(q0, frame, side)],
            "truth": [float(wt), run.wrist_error_mm(qt, frame, side)],
            "reach": [float(weights[k]), run.wrist_error_mm(particles[k], frame, side)]}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="+", type=Path)
    ap.add_argument("--min-error", type=float, default=120.0, help="wrist error (mm) of a frame probed")
    ap.add_argument("--every", type=int, default=1, help="probe every N-th such frame")
    ap.add_argument("--frames", help="comma-separated frames to probe instead (both arms)")
    ap.add_argument("--json", type=Path)
    args = ap.parse_args()
    rows = []
    for run_dir in args.runs:
        run = Run(run_dir)
        for side in SIDES:
            if args.frames:
                frames = [int(f) for f in args.frames.split(",")]
            else:
                frames = [f for f in run.frames
                          if run.wrist_error_mm(run.poses[f], f, side) > args.min_error][::args.every]
            for f in frames:
                rows.append(probe(run, f, side))
                r = rows[-1]
                print(f"{r['run']} frame {f} {side}: " + ", ".join(
                    f"{k} w {r[k][0]:.3f} wrist {r[k][1]:.0f} mm" for k in ("tracked", "truth", "reach")),
                    flush=True)
    gain = 1.0 + reach.MARGIN
    truth_wins = [r for r in rows if r["truth"][0] > r["tracked"][0] * gain]
    found = [r for r in rows if r["reach"][0] > r["tracked"][0] * gain]
    summary = {"frames": len(rows), "truth_beats_tracked": len(truth_wins),
               "reach_beats_tracked": len(found), "margin": reach.MARGIN,
               "reach_wrist_mm_when_kept": sorted(round(r["reach"][1]) for r in found)}
    print(f"{len(rows)} arms probed; the truth's arm beats the tracked one by {reach.MARGIN:.0%} in "
          f"{len(truth_wins)} (the search's failures, the rest the likelihood's); the reach "
          f"search's best does in {len(found)}, its wrist then "
          f"{summary['reach_wrist_mm_when_kept']} mm from the truth's")
    if args.json:
        args.json.write_text(json.dumps({"summary": summary, "rows": rows}, indent=1))


if __name__ == "__main__":
    main()
