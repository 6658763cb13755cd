"""Accuracy over every visible render: track each set with the same settings, score it, tabulate.

    python benchmarks/accuracy.py --out DIR [--sets walks4] [--python-path TREE] [-- TRACK ARGS]

For each set of ``../shared/data/mocap_walk_render`` (or ``$IPF_JAX_DATA``) named by ``--sets``, runs
``ipf-jax track SET --out DIR/runs/SET [TRACK ARGS]`` in a subprocess (``--python-path TREE`` runs the
ipf_jax found in TREE instead, e.g. a ``git worktree`` of another revision, so two versions can be
compared on the same machine), then scores ``joints.csv`` against ``ground_truth.csv`` on the 12
limb joints: MPJPE, the error left once each joint's constant offset is removed, the mean offset
(all 12, and hips/knees/ankles), lost frames (> 200 mm) and the worst five frames. Frames the
tracker declared ``lost`` (nan rows) are not scored in those; ``mpjpe_guess_mm`` and
``lost_frames_guess`` score every frame, with the lost frames' best guesses from ``run.json``
(``declared_lost`` counts them; without any, they equal the plain figures). Finished sets
are skipped on a rerun (delete ``DIR/runs/SET`` to redo one). Writes ``DIR/accuracy.json`` (every
number, per joint too) and ``DIR/accuracy.md`` (the table).

Set groups: ``walks4`` (every walk, 4 cameras, clean and noisy), ``walks4clean``, ``sts4``
(sit-to-stand, 4 cameras), ``fewcams`` (every 1- and 2-camera set), ``all``; or a comma list of
groups and set names (``walks4,sts4``).
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from ipf_jax.analysis.evaluation import evaluate_files
from ipf_jax.analysis.evaluation.metrics import (
    frame_errors,
    loss_summary,
    systematic_doc,
)
from ipf_jax.data.runfiles import JOINT_COLUMNS, read_joints_csv, write_rows
from ipf_jax.paths import shared_data_dir

WALKS = ("rajagopal_walk", "rajagopal_longlegs", "rajagopal_heavy", "rajagopal_walk_uu", "sub4_walk")
STS = ("sub4_sts", "sub4_sts_weaklegs")


def set_names(spec: str, root: Path) -> list[str]:
    have = sorted(p.name for p in root.iterdir() if (p / "ground_truth.csv").is_file())
    four = lambda motions, noise=("clean", "noisy"): [f"{m}_{n}_4cam" for m in motions for n in noise]  # noqa
    groups = {"walks4": four(WALKS), "walks4clean": four(WALKS, ("clean",)), "sts4": four(STS),
              "fewcams": [n for n in have if not n.endswith("_4cam")], "all": have}
    names = list(dict.fromkeys(n for item in spec.split(",") if item.strip()
                               for n in groups.get(item.strip(), [item.strip()])))
    missing = [n for n in names if n not in have]
    if missing:
        sys.exit(f"error: unknown set(s) {', '.join(missing)} (have: {', '.join(have)})")
    return names


def run_set(name: str, root: Path, out: Path, track_args: list[str], tree: str | None) -> dict:
    run_dir = out / "runs" / name
    done = run_dir / "run.json"
    if not (done.is_file() and (run_dir / "joints.csv").is_file() and json.loads(done.read_text())
            .get("frames", {}).get("done") == json.loads(done.read_text()).get("frames", {}).get("count")):
        env = dict(os.environ)
        if tree:
            env["PYTHONPATH"] = tree + os.pathsep + env.get("PYTHONPATH", "")
        t0 = time.perf_counter()
        proc = subprocess.run([sys.executable, "-m", "ipf_jax.cli.main", "track", str(root / name),
                               "--out", str(run_dir), "--quiet", *track_args], env=env,
                              capture_output=True, text=True, cwd="/")
        if proc.returncode != 0:
            return {"set": name, "error": (proc.stderr.strip().splitlines() or ["?"])[-1],
                    "wall_s": round(time.perf_counter() - t0, 1)}
    run = json.loads(done.read_text())
    declared = [r for r in run["per_frame"] if r["status"] == "lost"]
    if declared:  # scored with the best guesses too, so dropping frames cannot flatter the table
        ev, _, _ = evaluate_files(with_best_guesses(run_dir, run), root / name / "ground_truth.csv")
        guess = {"mpjpe_guess_mm": 1000 * ev.mpjpe_m,
                 "lost_frames_guess": loss_summary(frame_errors(ev))["lost_frames"]}
    ev, _, _ = evaluate_files(run_dir / "joints.csv", root / name / "ground_truth.csv")
    sysdoc = systematic_doc(ev)
    loss = loss_summary(frame_errors(ev))
    statuses = [r["status"] for r in run["per_frame"]]
    return {"set": name, "mpjpe_mm": 1000 * ev.mpjpe_m,
            "offset_free_mm": 1000 * sysdoc["mpjpe_offset_free_m"],
            "mean_offset_mm": 1000 * sysdoc["mean_offset_m"],
            "leg_offset_mm": 1000 * sysdoc["mean_leg_offset_m"],
            "worst5_mm": 1000 * loss["worst5_mean_m"], "lost_frames": loss["lost_frames"],
            "longest_lost_run": loss["longest_lost_run"], "recoveries": loss["recoveries_frames"],
            "height_m": run.get("height_m"), "frames": len(statuses),
            "reinit": sum(s.startswith("reinit") for s in statuses),
            "statuses": {s: statuses.count(s) for s in sorted(set(statuses))},
            "s_per_frame": run["seconds"]["per_tracked_frame_mean"],
            "init_evaluations": run.get("init_evaluations"),
            "evaluations_per_frame": run.get("evaluations_per_frame"),
            "declared_lost": len(declared), "mpjpe_guess_mm": 1000 * ev.mpjpe_m,
            "lost_frames_guess": loss["lost_frames"],
            **(guess if declared else {}),
            "recovery": {k: v for k, v in (run.get("recovery") or {}).items() if k != "per_attempt"},
            "per_joint": sysdoc["per_joint"]}


def with_best_guesses(run_dir: Path, run: dict) -> Path:
    """``joints.csv`` with each lost frame's best guess (``run.json``) in place of its nan row."""
    table = read_joints_csv(run_dir / "joints.csv")
    guesses = {r["frame"]: r["best_guess"]["points"] for r in run["per_frame"] if r["status"] == "lost"}
    points = table.points.copy()
    for i, f in enumerate(table.frame):
        if int(f) in guesses:
            points[i] = guesses[int(f)]
    out = run_dir / "joints_best_guess.csv"
    write_rows(out, JOINT_COLUMNS, table.frame, table.time_s, points.reshape(len(points), -1))
    return out


COLUMNS = ("set", "mpjpe_mm", "offset_free_mm", "mean_offset_mm", "leg_offset_mm", "worst5_mm",
           "mpjpe_guess_mm", "lost_frames", "lost_frames_guess", "longest_lost_run", "declared_lost",
           "reinit", "height_m", "s_per_frame")


def markdown(rows: list[dict]) -> str:
    def fmt(c, v):
        digits = {"height_m": 3, "s_per_frame": 2}.get(c, 1)
        return f"{v:.{digits}f}" if isinstance(v, float) else str(v)

    lines = ["| " + " | ".join(COLUMNS) + " |", "|" + "---|" * len(COLUMNS)]
    for r in rows:
        cells = [r["set"], f"error: {r['error']}"] if "error" in r else [fmt(c, r[c]) for c in COLUMNS]
        lines.append("| " + " | ".join(cells) + " |")
    ok = [r for r in rows if "error" not in r]
    if ok:
        lines.append("| **mean** | " + " | ".join(
            f"{np.mean([r[c] for r in ok]):.1f}" for c in COLUMNS[1:7]) + " |" + " |" * (len(COLUMNS) - 7))
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", required=True, help="output folder (runs/, accuracy.json, accuracy.md)")
    ap.add_argument("--sets", default="walks4", help="set group or comma list (see module doc)")
    ap.add_argument("--python-path", help="run the ipf_jax found in this folder (another revision)")
    ap.add_argument("track_args", nargs="*", help="options passed to ipf-jax track (after --)")
    args = ap.parse_args(argv)
    root = shared_data_dir() / "mocap_walk_render"
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    for name in set_names(args.sets, root):
        row = run_set(name, root, out, args.track_args, args.python_path)
        rows.append(row)
        print(" ".join(f"{c}={row[c]:.1f}" if isinstance(row.get(c), float) else f"{c}={row.get(c)}"
                       for c in COLUMNS if c in row) + (f" error={row['error']}" if "error" in row else ""),
              flush=True)
    doc = {"track_args": args.track_args, "python_path": args.python_path, "rows": rows}
    (out / "accuracy.json").write_text(json.dumps(doc, indent=1))
    (out / "accuracy.md").write_text(markdown(rows) + "\n")
    print(markdown(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
