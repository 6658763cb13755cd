"""What a perfect length fit would buy: each run's fitted shape with the truth's lengths put in,
tracked again with the body held.

    python benchmarks/shape_oracle.py --runs ACC --out DIR [--sets walks4clean]

``ACC`` is an ``accuracy.py --out`` folder (its ``runs/SET/shape.json``, seed 0, and its
``accuracy.json``). For each set the fitted shape gets the ground truth's thigh, shank, upper arm
and forearm lengths, hip and shoulder spacing (``shape_truth.truth_lengths``), its sole-to-ankle
height (the ankles' lowest centre over the clip: flat-foot stance) scaling the ankle group, and
its hip-to-shoulder distance (the mid-hip to mid-shoulder distance over the clip; the model's, in
its zero pose, matched by the ``trunk`` length alone); girths, foot, neck and head stay as
fitted. The set is then tracked with ``--shape`` (no fit; automatic initialisation, defaults) and
scored with ``ipf-jax eval``. A set whose truth falls outside the model's anthropometric bounds
is reported and skipped. Prints a markdown table (fitted run -> oracle run).
"""
from __future__ import annotations

import argparse
import csv
import json
import subprocess
import sys
from pathlib import Path

import numpy as np

from ipf_jax.body.model import NUM_DOF, POINT_INDEX
from ipf_jax.body.proportions import GROUPS, sole_to_ankle
from ipf_jax.body.shape import SHAPE_PARAM_NAMES, shape_from_json
from ipf_jax.errors import IPFError
from ipf_jax.geometry.kinematics import forward_kinematics
from ipf_jax.paths import shared_data_dir

sys.path.insert(0, str(Path(__file__).parent))
from accuracy import set_names  # noqa: E402
from shape_truth import truth_lengths  # noqa: E402

ANKLE = next(g for g in GROUPS if g.name == "ankle").params


def truth_heights(set_dir: Path) -> dict[str, float]:
    """The truth's sole-to-ankle height (lowest ankle centre over the floor) and mid-hip to
    mid-shoulder distance (mean over frames), metres."""
    meta = json.loads((set_dir / "meta.json").read_text())
    up = meta.get("up_axis", "+z")  # bodytrack's rig: world Z up, floor Z = 0
    sign, axis = (-1.0 if up.startswith("-") else 1.0), "xyz".index(up[-1])
    with open(set_dir / "ground_truth.csv") as fh:
        rows = list(csv.DictReader(fh))

    def p(j):
        return np.array([[float(r[f"{j}_{c}"]) for c in "xyz"] for r in rows])

    ankle = min(float((sign * p(f"{s}_ankle")[:, axis]).min()) for s in ("left", "right"))
    mid_hip = 0.5 * (p("left_hip") + p("right_hip"))
    mid_shoulder = 0.5 * (p("left_shoulder") + p("right_shoulder"))
    return {"ankle_height": ankle,
            "hip_to_shoulder": float(np.mean(np.linalg.norm(mid_shoulder - mid_hip, axis=1)))}


def _values(params: dict) -> np.ndarray:
    return np.array([params[n] for n in SHAPE_PARAM_NAMES], np.float64)


def hip_to_shoulder(v: np.ndarray) -> float:
    pts = forward_kinematics(np.zeros(NUM_DOF), v, np.eye(3), xp=np).points

    def mid(a):
        return 0.5 * (pts[POINT_INDEX[f"left_{a}"]] + pts[POINT_INDEX[f"right_{a}"]])

    return float(np.linalg.norm(mid("shoulder") - mid("hip")))


def oracle_params(fitted: dict, lengths: dict, heights: dict) -> dict:
    """The fitted params with the truth's lengths and heights put in (module docstring)."""
    p = {k: float(v) for k, v in fitted.items()}
    for k in ("thigh", "shank", "upper_arm", "forearm"):
        p[k] = lengths[k]
    p["hip_half_width"] = lengths["hip_spacing"] / 2
    p["shoulder_half_width"] = lengths["shoulder_width"] / 2
    scale = heights["ankle_height"] / float(sole_to_ankle(_values(p)))
    for n in ANKLE:
        p[n] *= scale
    lo, hi, base = 0.5, 2.0, p["trunk"]
    for _ in range(50):  # the trunk length that gives the truth's hip-to-shoulder distance
        p["trunk"] = base * 0.5 * (lo + hi)
        if hip_to_shoulder(_values(p)) < heights["hip_to_shoulder"]:
            lo = 0.5 * (lo + hi)
        else:
            hi = 0.5 * (lo + hi)
    return p


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", required=True, help="an accuracy.py --out folder (seed 0)")
    ap.add_argument("--out", required=True)
    ap.add_argument("--sets", default="walks4clean")
    args = ap.parse_args(argv)
    root = shared_data_dir() / "mocap_walk_render"
    runs, out = Path(args.runs), Path(args.out)
    scored = {r["set"]: r for r in json.loads((runs / "accuracy.json").read_text())["rows"]
              if r.get("seed", 0) == 0}
    lines = ["| set | MPJPE | offset-free | mean offset | hip/knee/ankle offset "
             "| hips' offset along up (L / R) |", "|---|---|---|---|---|---|"]
    for name in set_names(args.sets, root):
        fitted = json.loads((runs / "runs" / name / "shape.json").read_text())["params"]
        params = oracle_params(fitted, truth_lengths(root / name / "ground_truth.csv"),
                               truth_heights(root / name))
        doc = {"params": params, "source": "benchmarks/shape_oracle.py: the truth's lengths in "
                                            f"{runs / 'runs' / name / 'shape.json'}"}
        try:
            shape_from_json(doc)
        except IPFError as e:
            print(f"{name}: skipped, {e}", file=sys.stderr)
            continue
        run = out / name
        run.mkdir(parents=True, exist_ok=True)
        (run / "oracle_shape.json").write_text(json.dumps(doc, indent=1))
        for cmd in (["track", str(root / name), "--shape", str(run / "oracle_shape.json"), "--out", str(run)],
                    ["eval", str(run / "joints.csv"), str(root / name / "ground_truth.csv"),
                     "--out", str(run / "eval"), "--no-plots"]):
            proc = subprocess.run([sys.executable, "-m", "ipf_jax.cli.main", *cmd],
                                  capture_output=True, text=True)
            if proc.returncode:
                sys.exit(f"error: ipf-jax {cmd[0]} {name} failed:\n{proc.stderr[-2000:]}")
        ev = json.loads((run / "eval" / "eval.json").read_text())
        sysm, before = ev["systematic"], scored[name]
        up = json.loads((root / name / "meta.json").read_text()).get("up_axis", "+z")
        sign, axis = (-1.0 if up.startswith("-") else 1.0), "xyz".index(up[-1])

        def hips(per_joint):
            return " / ".join(f"{1000 * sign * per_joint[j]['offset_xyz_m'][axis]:+.0f}"
                              for j in ("left_hip", "right_hip"))

        lines.append(
            f"| {name} | {before['mpjpe_mm']:.1f} -> {1000 * ev['mpjpe_m']:.1f} | "
            f"{before['offset_free_mm']:.1f} -> {1000 * sysm['mpjpe_offset_free_m']:.1f} | "
            f"{before['mean_offset_mm']:.1f} -> {1000 * sysm['mean_offset_m']:.1f} | "
            f"{before['leg_offset_mm']:.1f} -> {1000 * sysm['mean_leg_offset_m']:.1f} | "
            f"{hips(before['per_joint'])} -> {hips(sysm['per_joint'])} |")
    print("\n".join(lines))
    print("\n(mm; the fitted run -> the same set tracked with the truth's lengths in its fitted shape)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
