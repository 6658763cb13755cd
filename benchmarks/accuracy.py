"""Accuracy over every visible render: track each set with the same settings, score it, tabulate.

    python benchmarks/accuracy.py --out DIR [--sets walks4] [--seeds 0] [--python-path TREE] [-- TRACK ARGS]

For each set of ``../shared/data/mocap_walk_render`` (or ``$IPF_JAX_DATA``) named by ``--sets``, runs
``ipf-jax track SET --out DIR/runs/SET [TRACK ARGS]`` in a subprocess (``--python-path TREE`` runs the
ipf_jax found in TREE instead, e.g. a ``git worktree`` of another revision, so two versions can be
compared on the same machine), then scores ``joints.csv`` against ``ground_truth.csv`` on the 12
limb joints: MPJPE, the error left once each joint's constant offset is removed, the mean offset
(all 12, and hips/knees/ankles), lost frames (> 200 mm) and the worst five frames. Frames the
tracker declared ``lost`` (nan rows) are not scored in those; ``mpjpe_guess_mm`` and
``lost_frames_guess`` score every frame, with the lost frames' best guesses from ``run.json``
(``declared_lost`` counts them; without any, they equal the plain figures). ``lowpass_mm`` scores
the joints low-passed as ``ipf-jax track --smooth`` writes them (``joints_smoothed.csv``: the gait
analysis' 5 Hz zero-lag Butterworth, docs/export.md), what a gait lab would filter the trajectories
to; ``fixed_mm`` (one-camera walks only: absent elsewhere) scores the run after ``ipf-jax
fix-single`` with its defaults (leg swaps corrected, the depth steadied along the camera's rays:
docs/single_camera.md; written to ``DIR/fixed/RUN``), what that page tells one-camera users to
run; its assumptions (a walk in a straight line) do not hold for the sit-to-stand (``_sts``) sets. The other
columns score the raw per-frame estimates of ``joints.csv``. Finished sets
are skipped on a rerun when the same ``ipf_jax`` sources (a hash of their files) and track options
made them (``DIR/runs/SET/accuracy_stamp.json``); a finished run made otherwise stops the script
with an error naming it, so another version's run is never scored as this one's (delete
``DIR/runs/SET`` to redo one). Writes ``DIR/accuracy.json`` (every
number, per joint too) and ``DIR/accuracy.md`` (the table).

``--seeds 0,1,2`` tracks every set once per seed (``--seed K``; runs in ``DIR/runs/SET@seedK``
when there is more than one seed) and adds a table over the seeds: per set the mean, lowest and
highest MPJPE, offset-free error and hip/knee/ankle offset. One seed's figure is one draw: on the
visible walks a set's MPJPE moves by up to 12 mm between seeds (and as much between machines with
the same seed: float rounding sends the searches down other paths), so compare defaults on the mean
over seeds and sets. ``accuracy.json`` records the library versions and the processor.

Set groups: ``walks4`` (every walk, 4 cameras, clean and noisy), ``walks4clean``, ``sts4``
(sit-to-stand, 4 cameras), ``fewcams`` (every 1- and 2-camera set), ``all``; or a comma list of
groups and set names (``walks4,sts4``). ``walks3`` (or a name ``SET_3cam``): the 4-camera walks
with their last camera left out, built under ``DIR/derived`` from links to the 4-camera set (no
visible render has three cameras).
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
    evaluate,
    frame_errors,
    loss_summary,
    systematic_doc,
)
from ipf_jax.analysis.export.smoothed import smooth_joints
from ipf_jax.analysis.singlecam import fix_single_camera
from ipf_jax.data.dataset import open_dataset
from ipf_jax.data.rundir import read_run
from ipf_jax.data.runfiles import JOINT_COLUMNS, read_joints_csv, write_rows
from ipf_jax.lowered import source_version
from ipf_jax.paths import shared_data_dir
from ipf_jax.profiling import machine

WALKS = ("rajagopal_walk", "rajagopal_longlegs", "rajagopal_heavy", "rajagopal_walk_uu", "sub4_walk")
STS = ("sub4_sts", "sub4_sts_weaklegs")


def set_names(spec: str, root: Path) -> list[str]:
    have = sorted(p.name for p in root.iterdir() if (p / "ground_truth.csv").is_file())
    have += [d for n in have if n.endswith("_4cam") for d in [n[:-len("_4cam")] + "_3cam"] if d not in have]
    four = lambda motions, noise=("clean", "noisy"): [f"{m}_{n}_4cam" for m in motions for n in noise]  # noqa
    groups = {"walks4": four(WALKS), "walks4clean": four(WALKS, ("clean",)), "sts4": four(STS),
              "walks3": [n[:-len("_4cam")] + "_3cam" for n in four(WALKS)],
              "fewcams": [n for n in have if n.endswith(("_1cam", "_2cam"))],
              "all": [n for n in have if not n.endswith("_3cam")]}
    names = list(dict.fromkeys(n for item in spec.split(",") if item.strip()
                               for n in groups.get(item.strip(), [item.strip()])))
    missing = [n for n in names if n not in have]
    if missing:
        sys.exit(f"error: unknown set(s) {', '.join(missing)} (have: {', '.join(have)})")
    return names


def three_camera_set(name: str, root: Path, out: Path) -> Path:
    """Build ``SET_3cam`` (``SET_4cam`` without its last camera) under ``out/derived`` from links;
    returns that folder (the root to track it from)."""
    if (root / name / "ground_truth.csv").is_file():  # a real 3-camera set
        return root
    src, derived = root / (name[:-len("_3cam")] + "_4cam"), out / "derived"
    dst = derived / name
    if not dst.is_dir():
        dst.mkdir(parents=True)
        for f in ("ground_truth.csv", "ground_truth_extra.csv", "meta.json", "visibility.csv",
                  "FG1", "FG2", "FG3"):
            if (src / f).exists():
                (dst / f).symlink_to((src / f).resolve())
        if (src / "dataset.json").is_file():  # an ipf-jax dataset: the cameras are listed
            doc = json.loads((src / "dataset.json").read_text())
            doc["cameras"] = doc["cameras"][:3]
            (dst / "dataset.json").write_text(json.dumps(doc, indent=1))
            (dst / "CALIB").symlink_to((src / "CALIB").resolve())
        else:  # bodytrack's layout: CALIB/CameraK.cal with FGK
            (dst / "CALIB").mkdir()
            for k in (1, 2, 3):
                (dst / "CALIB" / f"Camera{k}.cal").symlink_to((src / "CALIB" / f"Camera{k}.cal").resolve())
    return derived


STAMP = "accuracy_stamp.json"


def source_hash(tree: str | None) -> str:
    """The version of the ``ipf_jax`` sources a run uses (``tree``'s, or the one this script imports)."""
    import ipf_jax
    return source_version(Path(tree) / "ipf_jax" if tree else Path(ipf_jax.__file__).parent)[:16]


def run_set(name: str, root: Path, out: Path, track_args: list[str], tree: str | None,
            run_name: str | None = None, source: str = "", fixed: bool = False) -> dict:
    """Track one set (unless a finished run of the same sources and options is there) and score it;
    ``fixed``: a one-camera walk is scored after ``fix-single`` too (:func:`fixed_single`)."""
    run_dir = out / "runs" / (run_name or name)
    done = run_dir / "run.json"
    stamp = {"source": source, "track_args": track_args}
    finished = (done.is_file() and (run_dir / "joints.csv").is_file() and json.loads(done.read_text())
                .get("frames", {}).get("done") == json.loads(done.read_text()).get("frames", {}).get("count"))
    if finished:
        had = json.loads((run_dir / STAMP).read_text()) if (run_dir / STAMP).is_file() else None
        if had != stamp:  # a finished run of other sources or options is never scored as this one's
            sys.exit(f"error: {run_dir} holds a finished run of other ipf_jax sources or track options "
                     f"({'none recorded' if had is None else had}); delete it or use another --out")
    else:
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
        (run_dir / STAMP).write_text(json.dumps(stamp))
    run = json.loads(done.read_text())
    declared = [r for r in run["per_frame"] if r["status"] == "lost"]
    if declared:  # scored with the best guesses too, so dropping frames cannot flatter the table
        ev, _, _ = evaluate_files(with_best_guesses(run_dir, run), root / name / "ground_truth.csv")
        guess = {"mpjpe_guess_mm": 1000 * ev.mpjpe_m,
                 "lost_frames_guess": loss_summary(frame_errors(ev))["lost_frames"]}
    ev, est, truth = evaluate_files(run_dir / "joints.csv", root / name / "ground_truth.csv")
    low = evaluate(est._replace(points=smooth_joints(read_run(run_dir))[0]), truth)
    sysdoc = systematic_doc(ev)
    loss = loss_summary(frame_errors(ev))
    statuses = [r["status"] for r in run["per_frame"]]
    return {"set": name, "mpjpe_mm": 1000 * ev.mpjpe_m,
            "offset_free_mm": 1000 * sysdoc["mpjpe_offset_free_m"],
            "lowpass_mm": 1000 * low.mpjpe_m,
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
            **(fixed_single(run_dir, root / name, out / "fixed" / (run_name or name), run) if fixed else {}),
            "per_joint": sysdoc["per_joint"]}


def fixed_single(run_dir: Path, data_dir: Path, fixed_dir: Path, run: dict) -> dict:
    """A one-camera walk's run after ``ipf-jax fix-single`` (its defaults), scored:
    ``fixed_mm`` and ``fixed_offset_free_mm``; nothing for other runs."""
    used = run.get("cameras") or []
    if len(used) != 1 or "_sts" in data_dir.name:
        return {}
    camera = {c.name: c for c in open_dataset(data_dir).cameras}[used[0]]
    fix_single_camera(run_dir, fixed_dir, camera=camera)
    ev, _, _ = evaluate_files(fixed_dir / "joints.csv", data_dir / "ground_truth.csv")
    return {"fixed_mm": 1000 * ev.mpjpe_m,
            "fixed_offset_free_mm": 1000 * systematic_doc(ev)["mpjpe_offset_free_m"]}


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


COLUMNS = ("set", "mpjpe_mm", "offset_free_mm", "lowpass_mm", "mean_offset_mm", "leg_offset_mm", "worst5_mm",
           "mpjpe_guess_mm", "lost_frames", "lost_frames_guess", "longest_lost_run", "declared_lost",
           "reinit", "height_m", "s_per_frame")


def markdown(rows: list[dict]) -> str:
    def fmt(c, v):
        digits = {"height_m": 3, "s_per_frame": 2}.get(c, 1)
        return f"{v:.{digits}f}" if isinstance(v, float) else str(v)

    lines = ["| " + " | ".join(COLUMNS) + " |", "|" + "---|" * len(COLUMNS)]
    several = len({r.get("seed") for r in rows}) > 1
    for r in rows:
        cells = [r["set"], f"error: {r['error']}"] if "error" in r else [fmt(c, r[c]) for c in COLUMNS]
        if several:
            cells[0] += f" (seed {r['seed']})"
        lines.append("| " + " | ".join(cells) + " |")
    ok = [r for r in rows if "error" not in r]
    if ok:
        lines.append("| **mean** | " + " | ".join(
            f"{np.mean([r[c] for r in ok]):.1f}" for c in COLUMNS[1:8]) + " |" + " |" * (len(COLUMNS) - 8))
        lines += fixed_markdown([r for r in ok if "fixed_mm" in r], several)
    return "\n".join(lines)


FIXED_COLUMNS = ("mpjpe_mm", "fixed_mm", "offset_free_mm", "fixed_offset_free_mm")


def fixed_markdown(rows: list[dict], several: bool) -> list[str]:
    """The one-camera walks' rows before and after ``fix-single`` (no lines without any)."""
    if not rows:
        return []
    lines = ["", "One-camera walks after `ipf-jax fix-single` (leg swaps, steady depth):", "",
             "| set | " + " | ".join(FIXED_COLUMNS) + " |", "|---" * (len(FIXED_COLUMNS) + 1) + "|"]
    for r in rows:
        name = r["set"] + (f" (seed {r['seed']})" if several else "")
        lines.append(f"| {name} | " + " | ".join(f"{r[c]:.1f}" for c in FIXED_COLUMNS) + " |")
    means = [f"{np.mean([r[c] for r in rows]):.1f}" for c in FIXED_COLUMNS]
    lines.append("| **mean** | " + " | ".join(means) + " |")
    return lines


SEED_COLUMNS = ("mpjpe_mm", "offset_free_mm", "leg_offset_mm")


def over_seeds(rows: list[dict]) -> list[dict]:
    """Per set: mean, lowest and highest of :data:`SEED_COLUMNS` over its seeds' rows."""
    out = []
    for name in dict.fromkeys(r["set"] for r in rows):
        ok = [r for r in rows if r["set"] == name and "error" not in r]
        if ok:
            out.append({"set": name, "seeds": [r["seed"] for r in ok],
                        **{c: {"mean": float(np.mean([r[c] for r in ok])), "min": float(min(r[c] for r in ok)),
                               "max": float(max(r[c] for r in ok))} for c in SEED_COLUMNS}})
    return out


def seeds_markdown(table: list[dict]) -> str:
    head = ["set", "seeds"] + [f"{c} mean (min-max)" for c in SEED_COLUMNS]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in table:
        lines.append(f"| {r['set']} | {len(r['seeds'])} | " + " | ".join(
            f"{r[c]['mean']:.1f} ({r[c]['min']:.1f}-{r[c]['max']:.1f})" for c in SEED_COLUMNS) + " |")
    if table:
        lines.append("| **mean** | | " + " | ".join(
            f"{np.mean([r[c]['mean'] for r in table]):.1f}" for c in SEED_COLUMNS) + " |")
    return "\n".join(lines)


def environment() -> dict:
    """What produced the numbers: the host (:func:`ipf_jax.profiling.machine`) and the library
    versions."""
    from importlib import metadata

    def version(dist):
        try:
            return metadata.version(dist)
        except metadata.PackageNotFoundError:
            return None

    return {**machine(), **{d: version(d) for d in ("ipf-jax", "jax", "jaxlib", "numpy", "scipy",
                                                     "opencv-python-headless")}}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", required=True, help="output folder (runs/, accuracy.json, accuracy.md)")
    ap.add_argument("--sets", default="walks4", help="set group or comma list (see module doc)")
    ap.add_argument("--seeds", default="0", help="comma list of seeds: every set once per seed")
    ap.add_argument("--python-path", help="run the ipf_jax found in this folder (another revision)")
    ap.add_argument("track_args", nargs="*", help="options passed to ipf-jax track (after --)")
    args = ap.parse_args(argv)
    try:
        seeds = [int(k) for k in args.seeds.split(",") if k.strip()]
    except ValueError:
        sys.exit(f"error: --seeds must be a comma list of integers, got {args.seeds!r}")
    if not seeds or "--seed" in args.track_args:
        sys.exit("error: give the seeds with --seeds (not --seed after --)")
    root = shared_data_dir() / "mocap_walk_render"
    out = Path(args.out).resolve()  # the runs start in / (cwd="/"): a relative --out must not follow them
    out.mkdir(parents=True, exist_ok=True)
    source = source_hash(args.python_path)
    rows = []
    for seed, name in ((k, n) for k in seeds for n in set_names(args.sets, root)):
        src = three_camera_set(name, root, out) if name.endswith("_3cam") else root
        row = run_set(name, src, out, [*args.track_args, "--seed", str(seed)], args.python_path,
                      name if len(seeds) == 1 else f"{name}@seed{seed}", source, fixed=True)
        row["seed"] = seed
        rows.append(row)
        print(f"seed={seed} " * (len(seeds) > 1) + " ".join(f"{c}={row[c]:.1f}" if isinstance(row.get(c), float) else f"{c}={row.get(c)}"
                       for c in COLUMNS if c in row) + (f" error={row['error']}" if "error" in row else ""),
              flush=True)
    doc = {"track_args": args.track_args, "seeds": seeds, "python_path": args.python_path,
           "environment": environment(), "rows": rows}
    text = markdown(rows)
    if len(seeds) > 1:
        doc["over_seeds"] = over_seeds(rows)
        text += "\n\nOver the seeds " + ", ".join(map(str, seeds)) + ":\n\n" + seeds_markdown(doc["over_seeds"])
    (out / "accuracy.json").write_text(json.dumps(doc, indent=1))
    (out / "accuracy.md").write_text(text + "\n")
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
