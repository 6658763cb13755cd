"""``ipf-jax score DATASET --frame K --poses P.csv --out F.json``: the likelihood of given poses."""
from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

from ..data.runfiles import read_pose_rows
from ..errors import require
from .options import add_common, add_option, check_args


def add_parser(sub) -> None:
    p = sub.add_parser("score", help="likelihood of given poses on one frame (JAX and/or NumPy)",
                       description="Score every pose of a poses.csv-convention file on one frame: "
                                   "Nc, Ns, Nm and w per camera, and the mean w (docs/formats.md).")
    p.add_argument("dataset", help="a dataset folder (bodytrack layout or a dataset.json)")
    p.add_argument("--frame", type=int, required=True, help="the frame number to score on")
    p.add_argument("--poses", required=True, help="CSV with one named column per DOF (poses.csv convention)")
    add_common(p, "out", help="output JSON file")
    add_common(p, "backend", default="jax", choices=["jax", "numpy", "both"],
               help="jax (the scorer), numpy (the NumPy reference, exact integers) or both, compared")
    for key in ("resolution", "height_m", "shape_file", "up_axis"):
        add_option(p, key)
    p.set_defaults(func=run)


def run(args) -> int:
    from ..body.shape import default_shape, load_shape
    from ..data.dataset import open_dataset
    from ..data.runfiles import check_output_file
    from ..data.silhouette import resize_mask
    from ..geometry.world import detect_up_axis, up_rotation
    from ..likelihood.scorer import (
        Scorer,
        make_observation,
        scoring_cameras,
        weights_from_counts,
    )
    from ..reference import likelihood as ref
    from ..tracking.tracker import DEFAULT_RESOLUTION

    check_args(args)  # each option's rule, and --shape with a --height that disagrees
    out_file = check_output_file(Path(args.out))  # before the scoring, not after it
    ds = open_dataset(args.dataset)
    require(args.frame in ds.frames, f"frame {args.frame} is not in the dataset "
            f"({min(ds.frames)}..{max(ds.frames)})", ds.path)
    poses = read_pose_rows(args.poses)
    shape = load_shape(args.shape_file) if args.shape_file else default_shape()
    if args.height_m:
        shape = shape.scaled_to(args.height_m)
    masks = ds.masks(args.frame)
    up = args.up_axis or ds.up_axis or detect_up_axis(ds.cameras, masks)
    U = up_rotation(up)
    cams, scales = scoring_cameras(ds.cameras, args.resolution if args.resolution is not None
                                   else DEFAULT_RESOLUTION)
    small = [m if s == 1.0 else resize_mask(m, c.height, c.width) for m, s, c in zip(masks, scales, cams)]
    obs = make_observation(small)
    out = {"dataset": str(ds.path), "frame": args.frame, "up_axis": up,
           "scoring_sizes": [[c.width, c.height] for c in cams], "cameras": [c.name for c in ds.cameras],
           "height_m": shape.height_m, "skipped_cameras": [c.name for c, a in zip(ds.cameras, obs.active) if not a]}
    results = {}
    backends = ["jax", "numpy"] if args.backend == "both" else [args.backend]
    for backend in backends:
        t0 = time.perf_counter()
        if backend == "jax":
            scorer = Scorer(cams, shape, U)
            scorer.counts(poses, obs)  # compile outside the timing
            t0 = time.perf_counter()
            counts = scorer.counts(poses, obs)
        else:
            counts = ref.counts(poses, shape.values, U, cams, small)
        seconds = time.perf_counter() - t0
        w, w_cam = weights_from_counts(counts, obs.active)
        results[backend] = counts
        out[backend] = {
            "seconds": round(seconds, 6), "particles_per_s": round(len(poses) / max(seconds, 1e-9), 1),
            "poses": [{"row": i, "w": None if np.isnan(w[i]) else float(w[i]),
                       "cameras": [{"name": c.name, "nc": int(counts[i, k, 0]), "ns": int(counts[i, k, 1]),
                                    "nm": int(counts[i, k, 2]),
                                    "w": None if np.isnan(w_cam[i, k]) else float(w_cam[i, k])}
                                   for k, c in enumerate(ds.cameras)]} for i in range(len(poses))]}
    if len(results) == 2:
        diff = np.abs(results["jax"] - results["numpy"])
        out["agreement"] = {"max_abs_count_difference": int(diff.max()),
                            "identical_fraction": float(np.mean(np.all(diff == 0, axis=-1))),
                            "note": "geometry is float32 (JAX) vs float64 (NumPy); the raster stage "
                                    "is exact, so differences come only from boundary pixels"}
    out_file.write_text(json.dumps(out, indent=1))
    for backend in backends:
        ws = [p["w"] for p in out[backend]["poses"]]
        print(f"{backend}: {len(poses)} poses, {out[backend]['particles_per_s']} poses/s, "
              f"w = {', '.join(f'{x:.4f}' if x is not None else 'nan' for x in ws[:6])}"
              f"{' ...' if len(ws) > 6 else ''}")
    if "agreement" in out:
        print(f"JAX vs NumPy: max count difference {out['agreement']['max_abs_count_difference']} px")
    print(f"wrote {args.out}")
    return 0
