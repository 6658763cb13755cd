"""SELF-RENDERED: can the shape fit find a body it could draw exactly?

    python benchmarks/shape_recovery.py --out DIR [--seeds 0,1] [--bodies template_shod,long_legs]
        [--passes 2] [--fit-from-truth DEG]

Each body below is the model's own template with some group factors changed, scaled to 1.80 m.
A procedural walk (24 frames, 20 Hz) of that body is rendered by the tracker's own capsule model
into 4 virtual ring cameras on the walk's diagonals (320 x 240), then tracked with the defaults
(automatic initialisation, shape fit). The masks are exact for the model, so what is left is the
fit's and the tracker's own error, without the model mismatch of the mocap renders: the fitted
factors against the true ones, the fitted thigh, shank and sole-to-ankle height against the
truth's, and the 12 limb joints' MPJPE and hip/knee/ankle constant offset. It is **not** an
accuracy claim: docs/shape_fit.md uses it to tell the fit's own error from the model's.

``--passes 2`` tracks in two passes (``ipf_jax.tracking.passes``: the shape refitted on the
tracked frames, then tracked again). ``--fit-from-truth DEG`` tracks nothing: the shape fit alone
(``fit_shape``, the defaults for 4 cameras) runs on the 8 frames the tracker would choose, seeded
with the truth's own poses (DEG = 0: one exact pose per frame; DEG > 0: 4 poses per frame with
every joint angle and the root's rotation moved by N(0, DEG) degrees and the root by N(0, DEG / 2)
cm), from the template at 1.75 m with its feet on the floor: can the fit find the body when the
poses are (nearly) right? Its rows have no joint errors.

Writes DIR/<body>_s<seed>/ (the dataset and the run) and DIR/shape_recovery.json, and prints a
markdown table.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from ipf_jax.analysis.evaluation.metrics import LEG_JOINTS, split_offsets
from ipf_jax.body.model import LIMB_JOINTS, POINT_NAMES
from ipf_jax.body.proportions import GROUP_NAMES, build, group_factors, sole_to_ankle, stature
from ipf_jax.body.shape import BodyShape, default_shape, shape_from_json
from ipf_jax.data.dataset import open_dataset
from ipf_jax.tracking import shape_fit as sf
from ipf_jax.tracking.initialise import InitSettings
from ipf_jax.tracking.passes import track
from ipf_jax.tracking.shape_fit import ShapeFitSettings
from ipf_jax.tracking.tracker import Tracker, TrackSettings
from ipf_jax.viz import synthetic as syn

HEIGHT_M = 1.80
FPS = 20.0
FRAMES = 24
#: group factors over the template's ratios (the others 1); every body wears shoes (ankle 1.7,
#: the fit's prior) but "barefoot", which is the demo's body
BODIES = {
    "template_shod": {"ankle": 1.7},
    "barefoot": {},
    "long_legs": {"thigh": 1.10, "shank": 1.08, "trunk": 0.88, "ankle": 1.7, "pelvis": 0.9,
                  "shoulders": 0.9, "leg_girth": 0.9, "torso_girth": 0.9},
    "short_legs_heavy": {"thigh": 0.91, "shank": 0.92, "trunk": 1.10, "ankle": 1.5, "pelvis": 1.08,
                         "shoulders": 1.08, "leg_girth": 1.2, "torso_girth": 1.2, "arm_girth": 1.15},
}
REPORTED = ("thigh", "shank", "ankle", "trunk", "pelvis", "shoulders", "leg_girth", "torso_girth")


def body(name: str) -> BodyShape:
    """The named body at :data:`HEIGHT_M`."""
    ref = default_shape(1.75).values
    theta = np.zeros(len(GROUP_NAMES))
    for g, f in BODIES[name].items():
        theta[GROUP_NAMES.index(g)] = np.log(f)
    # factors are ratios to stature, which the chain's groups make up: the factors a body really
    # has (reported as the truth) differ from these by the stature's change
    values = build(ref, theta, height_m=HEIGHT_M)
    return BodyShape(values, float(stature(values)))


def scene_of(name: str, out: Path):
    """The body, its walk's poses and the rendered data set (written once)."""
    shape = body(name)
    # on the diagonals of the walk: a ring at 0/90/180/270 deg sees mirror pairs, whose
    # silhouettes cannot tell the left leg from the right
    cams = syn.ring_cameras(4, radius=4.0, focal_px=380.0, first_angle_deg=-45.0)
    q = syn.procedural_walk(FRAMES, FPS, shape=shape, heading_deg=10.0, start=(-0.5, -0.2))
    data = out / "dataset"
    if not (data / "dataset.json").exists():
        syn.write_dataset(data, cams, syn.render_masks(q, shape, cams))
    return shape, q, data


def fit_from_truth(data: Path, q: np.ndarray, noise_deg: float, seed: int) -> tuple[BodyShape, dict]:
    """The shape fit alone, seeded with the truth's poses (module doc, ``--fit-from-truth``)."""
    scene = Tracker(open_dataset(data), TrackSettings(seed=seed, fps=FPS)).fit_scene()
    ref = default_shape(1.75)
    rng = np.random.default_rng(seed)
    poses = {}
    for f in sf.spread_frames(list(scene.frames), ShapeFitSettings().frames):
        p = np.repeat(q[f][None], 4 if noise_deg > 0 else 1, 0)
        p[:, :3] += rng.normal(0.0, noise_deg / 200, (len(p), 3))
        p[:, 3:] += np.deg2rad(rng.normal(0.0, noise_deg, (len(p), p.shape[1] - 3)))
        values = np.broadcast_to(ref.values, (len(p), len(ref.values)))
        poses[f] = scene.limits.clip(sf.place_on_floor_many(p, values, scene.U))
    res = sf.fit_on_poses(scene, poses, ref, height_m=None, seed=seed)
    return res.shape, {"evaluations": res.evaluations, "score_history": res.doc["score_history"]}


def run_one(name: str, seed: int, out: Path, passes: int = 1, truth_noise: float | None = None) -> dict:
    shape, q, data = scene_of(name, out)
    row = {"body": name, "seed": seed, "self_rendered": True, "passes": passes,
           "fit_from_truth_deg": truth_noise}
    if truth_noise is not None:
        fitted, info = fit_from_truth(data, q, truth_noise, seed)
        row["fit"] = info
    else:
        res = track(open_dataset(data), out / "run", TrackSettings(
            seed=seed, fps=FPS, init=InitSettings(), shape_fit=ShapeFitSettings(), passes=passes))
        fitted = shape_from_json(res.run["shape"])
        truth = syn.joints_of(q, shape)
        limb = [POINT_NAMES.index(j) for j in LIMB_JOINTS]
        split = split_offsets(res.joints[:, limb] - truth[:, limb], LIMB_JOINTS)
        legs = [LIMB_JOINTS.index(j) for j in LEG_JOINTS]
        row.update({
            "mpjpe_mm": round(1000 * float(split.mpjpe_m.mean()), 2),
            "offset_free_mm": round(1000 * float(split.offset_free_m.mean()), 2),
            "leg_offset_mm": round(1000 * float(split.offset_m[legs].mean()), 2),
            "leg_offset_up_mm": {j: round(1000 * float(split.offset[LIMB_JOINTS.index(j), 2]), 1)
                                 for j in LEG_JOINTS},
            "fit_seconds": res.run.get("shape_fit", {}).get("seconds")})
    true_f = dict(zip(GROUP_NAMES, group_factors(shape.values)))
    fit_f = dict(zip(GROUP_NAMES, group_factors(fitted.values)))
    mm = {k: 1000 * float(v) for k, v in (
        ("thigh_true", shape["thigh"]), ("thigh_fit", fitted["thigh"]),
        ("shank_true", shape["shank"]), ("shank_fit", fitted["shank"]),
        ("ankle_true", sole_to_ankle(shape.values)), ("ankle_fit", sole_to_ankle(fitted.values)))}
    row.update({"height_true_m": shape.height_m, "height_fit_m": fitted.height_m,
                "factors_true": {g: round(float(true_f[g]), 4) for g in GROUP_NAMES},
                "factors_fit": {g: round(float(fit_f[g]), 4) for g in GROUP_NAMES},
                "lengths_mm": {k: round(v, 1) for k, v in mm.items()}})
    return row


def table(rows: list[dict]) -> str:
    head = ("| body, seed | MPJPE | offset-free | hip/knee/ankle offset | hips up L / R | "
            + " | ".join(f"{g} true -> fit" for g in REPORTED) + " | thigh / shank / ankle mm, fit - true |")
    lines = [head, "|" + "---|" * (head.count("|") - 1)]
    for r in rows:
        ft, ff, L = r["factors_true"], r["factors_fit"], r["lengths_mm"]
        up = r.get("leg_offset_up_mm", {"left_hip": np.nan, "right_hip": np.nan})  # none: fit alone
        mpjpe, free, legs = (r.get(k, np.nan) for k in ("mpjpe_mm", "offset_free_mm", "leg_offset_mm"))
        lines.append(
            f"| {r['body']} s{r['seed']} | {mpjpe:.1f} | {free:.1f} | "
            f"{legs:.1f} | {up['left_hip']:+.0f} / {up['right_hip']:+.0f} | "
            + " | ".join(f"{ft[g]:.2f} -> {ff[g]:.2f}" for g in REPORTED)
            + f" | {L['thigh_fit'] - L['thigh_true']:+.0f} / {L['shank_fit'] - L['shank_true']:+.0f}"
            f" / {L['ankle_fit'] - L['ankle_true']:+.0f} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", required=True)
    ap.add_argument("--seeds", default="0")
    ap.add_argument("--bodies", default=",".join(BODIES))
    ap.add_argument("--passes", type=int, choices=(1, 2), default=1)
    ap.add_argument("--fit-from-truth", type=float, default=None, metavar="DEG",
                    help="no tracking: the shape fit seeded with the truth's poses, DEG of noise")
    a = ap.parse_args(argv)
    out = Path(a.out)
    names = a.bodies.split(",")
    unknown = [n for n in names if n not in BODIES]
    if unknown:
        print(f"error: unknown body {unknown[0]!r} (known: {', '.join(BODIES)})", file=sys.stderr)
        return 2
    if a.fit_from_truth is not None and not a.fit_from_truth >= 0:
        print(f"error: --fit-from-truth must be >= 0 degrees (got {a.fit_from_truth})", file=sys.stderr)
        return 2
    rows = []
    for seed in (int(s) for s in a.seeds.split(",")):
        for name in names:
            rows.append(run_one(name, seed, out / f"{name}_s{seed}", a.passes, a.fit_from_truth))
            (out / "shape_recovery.json").write_text(json.dumps({"rows": rows}, indent=1))
            print(table(rows[-1:]), flush=True)
    print(table(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
