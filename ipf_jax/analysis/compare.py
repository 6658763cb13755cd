"""``ipf-jax compare``: the filters side by side on the same frames, likelihood and budget.

Every filter (IPF, APF, SIR; :mod:`ipf_jax.filters`) tracks the same frames with the same scorer,
limits, seed and likelihood budget (evaluations per frame, mapped onto each filter by
:func:`ipf_jax.filters.registry.make`), from the same initial pose:

* the initial pose is ``settings.init_pose`` (``--init-pose``), or the automatic initialisation run
  **once** on the first frame, whose best pose then seeds every filter;
* that pose is the state *before* the first frame (bodytrack's convention for ``InitialPose.txt``),
  so every filter steps on every compared frame: each run tracks ``[A, A, A+1, ...]`` and its first
  row (status ``init`` in ``run.json``) is the shared initial pose, left out of the tables;
* re-initialisation on a confidence drop is off, so the runs differ only by their filter.

Each filter's run folder is ``DIR/<filter>/`` (joints.csv, poses.csv, run.json as the tracker
writes them, with the heaviest particle; plus ``joints_mean.csv``, the weighted mean). Each step is
timed and its likelihood evaluations are counted on the scorer itself. Against references
(a truth CSV in the ``joints.csv`` convention, or a bodytrack poses file turned into joints with
:mod:`ipf_jax.analysis.bodytrack`) the mean 3D distance of the shared limb joints is reported for both of
each filter's estimates: the heaviest particle (what ``joints.csv`` holds) and the weighted mean.
Outputs: ``compare.csv`` (one row per filter), ``compare_frames.csv``, ``compare.md``,
``compare.json`` and ``compare.png``. See docs/compare.md.
"""
from __future__ import annotations

import csv
import os
import time
from functools import partial
from pathlib import Path
from typing import NamedTuple, Sequence

import jax
import numpy as np

from ..body.model import LIMB_JOINTS, POINT_NAMES
from ..data.dataset import Dataset
from ..data.runfiles import (
    JOINT_COLUMNS,
    CsvAppender,
    check_writable,
    read_joints_csv,
    write_json_atomic,
)
from ..errors import require
from ..filters import registry
from ..filters.base import Filter
from ..geometry.host import forward_kinematics
from ..tracking.settings import DEFAULT_FPS
from ..tracking.tracker import Tracker, TrackSettings


class Reference(NamedTuple):
    """Joints to measure the filters against.

    label : 'truth' or 'peer' (column prefix);  frames : (F,) dataset frame numbers;
    points : (F, J, 3) world metres;  names : (J,) point names;  path : the source file.
    """

    label: str
    frames: np.ndarray
    points: np.ndarray
    names: tuple[str, ...]
    path: str


def load_truth(path: str | Path) -> Reference:
    """A CSV in the ``joints.csv`` convention (frame, time_s, <point>_x/_y/_z; metres)."""
    table = read_joints_csv(path)
    require(any(j in table.names for j in LIMB_JOINTS),
            f"no limb joint columns ({', '.join(LIMB_JOINTS[:3])}, ...)", path)
    return Reference("truth", table.frame, table.points, table.names, str(path))


def load_peer(path: str | Path, dataset: Dataset, shape_file: str | Path | None = None) -> Reference:
    """A bodytrack ``poses.txt`` (one pose per line): line k is the dataset's k-th frame.

    The body shape is ``shape_file`` or ``BodyShapeParameters.txt`` in the dataset folder.
    """
    from .bodytrack import peer_joints

    path = Path(path)
    require(path.is_file(), "bodytrack poses file not found", path)  # said before its shape's absence
    if shape_file is None:
        shape_file = Path(dataset.path) / "BodyShapeParameters.txt"
        require(shape_file.is_file(), "bodytrack poses need the body shape: no "
                f"BodyShapeParameters.txt in {dataset.path} (give --peer-shape)", path)
    points, names = peer_joints(path, shape_file)  # (F, J, 3)
    require(len(points) <= len(dataset.frames), f"{len(points)} poses but the dataset has only "
            f"{len(dataset.frames)} frames", path)
    return Reference("peer", np.array(dataset.frames[: len(points)]), points, tuple(names), str(path))


class StepLog(NamedTuple):
    """What one filter step did: its info, wall / CPU / likelihood seconds, scorer evaluations."""

    info: object
    seconds: float
    cpu_seconds: float
    likelihood_seconds: float
    evaluations: int


def recording(f: Filter, scorer, log: list[StepLog]) -> Filter:
    """``f`` with a step that appends a :class:`StepLog` to ``log`` (same results otherwise)."""

    def step(rng_key, state, measure, **drawn):
        spent = [0.0]

        def timed(particles, *args):
            t = time.perf_counter()
            w = measure(particles, *args)
            spent[0] += time.perf_counter() - t
            return w

        n0, t0, c0 = scorer.evaluations, time.perf_counter(), time.process_time()
        state, info = f.step(rng_key, state, timed, **drawn)
        log.append(StepLog(info, time.perf_counter() - t0, time.process_time() - c0, spent[0],
                           scorer.evaluations - n0))
        return state, info

    return f._replace(step=step)


def fastest(repeats: Sequence[StepLog]) -> StepLog:
    """One step's log over repeated runs: the last info, the least-disturbed (minimum) times."""
    return repeats[-1]._replace(**{k: min(getattr(r, k) for r in repeats)
                                   for k in ("seconds", "cpu_seconds", "likelihood_seconds")})


class CompareResult(NamedTuple):
    """rows : one dict per filter (compare.csv);  frame_rows : one per filter and frame;
    doc : everything, as written to compare.json;  files : the paths written."""

    rows: list[dict]
    frame_rows: list[dict]
    doc: dict
    files: list[Path]


def parse_filters(text: str | Sequence[str]) -> list[str]:
    """"ipf,apf,sir" (or a list) -> known, distinct filter names, in the order given."""
    names = [s.strip() for s in text.split(",")] if isinstance(text, str) else list(text)
    names = [n for n in names if n]
    require(bool(names), "no filter to compare (e.g. --filters ipf,apf,sir)")
    for n in names:
        registry.check_name(n)
    require(len(set(names)) == len(names), f"a filter is listed twice: {','.join(names)}")
    return names


def _initial_pose(dataset: Dataset, settings: TrackSettings, first: int) -> tuple[TrackSettings, int]:
    """Settings with the shared initial pose and height (automatic initialisation run once)."""
    probe = Tracker(dataset, settings, [first])
    seen = probe.observe(first)
    obs, small = seen.obs, seen.masks
    require(bool(obs.active.any()), f"frame {first} has no silhouette in any camera: start the "
            "comparison on a frame where the subject is seen (--frames)", dataset.path)
    if settings.init_pose is not None:
        return settings, 1
    q, w, shape, n = probe.initialise(first, obs, small, None)
    return settings._replace(init_pose=q[int(np.nanargmax(w))], height_m=shape.height_m), n


def _distances(ref: Reference, frame: int, best: np.ndarray, mean: np.ndarray) -> tuple[float, float]:
    """Mean distance (m) of the shared limb joints for both estimates; nan when ``frame`` is absent."""
    from .bodytrack import mean_joint_distance

    hit = np.nonzero(ref.frames == frame)[0]
    if len(hit) == 0:
        return np.nan, np.nan
    joints = [j for j in LIMB_JOINTS if j in ref.names]
    theirs = ref.points[hit[0]]
    return tuple(mean_joint_distance(ours, theirs, joints=joints, theirs_names=ref.names)
                 for ours in (best, mean))


def compare(dataset: Dataset, out_dir: str | Path, filters: str | Sequence[str], budget: int, *,
            settings: TrackSettings = TrackSettings(), frames: list[int] | None = None,
            references: Sequence[Reference] = (), peer_seconds: float | None = None,
            repeat: int = 1, progress: bool = True) -> CompareResult:
    """Run every filter on the same frames at the same budget and write the comparison.

    dataset : any :class:`~ipf_jax.data.dataset.Dataset`;  filters : names or "ipf,apf,sir";
    budget : likelihood evaluations per frame (required: the comparison is at equal cost);
    settings : the shared tracking settings (``filter``, ``budget`` and ``confidence_drop`` are
    set here; ``filter_options`` are routed to the filters that understand them);
    references : from :func:`load_truth` / :func:`load_peer`;  peer_seconds : the peer's measured
    seconds per frame, shown in the table beside ours;  repeat : run each filter this many times
    (identical runs) and time each step by its fastest repeat, so no step pays a compilation.
    """
    names = parse_filters(filters)
    require(repeat >= 1, f"--repeat must be >= 1 (got {repeat})")
    require(budget is not None, "the comparison needs --budget (evaluations per frame)")
    frames = list(frames if frames is not None else dataset.frames)
    require(len(frames) > 0, "no frames to compare (check --frames)")
    given = {k: v for k, v in settings.filter_options.items() if v is not None}
    unused = sorted(k for k in given if not any(k in registry.OPTIONS[n] for n in names))
    require(not unused, f"option(s) {', '.join(unused)} apply to none of {', '.join(names)}")
    per_filter = {n: settings._replace(filter=n, filter_options=registry.options_for(n, given),
                                       budget=budget, confidence_drop=0.0) for n in names}
    fps = settings.fps or dataset.fps or DEFAULT_FPS
    for n in names:  # fail on impossible settings before any tracking
        registry.resolve(n, per_filter[n].filter_options, fps, budget=budget)
    for ref in references:  # a reference of other frames would leave its columns blank
        require(bool(np.isin(frames, ref.frames).any()), f"the {ref.label} file shares no frame "
                f"number with the frames compared ({min(frames)}..{max(frames)}; it has "
                f"{int(ref.frames.min())}..{int(ref.frames.max())})", ref.path)
    out_dir = check_writable(Path(out_dir))
    load = [os.getloadavg()[0]]
    shared, init_evals = _initial_pose(dataset, per_filter[names[0]], frames[0])
    runs = {}
    for n in names:
        logs: list[list[StepLog]] = []
        for _ in range(repeat):  # same seed: the same run again, for its timing
            tracker = Tracker(dataset, shared._replace(filter=n, filter_options=per_filter[n].filter_options),
                              [frames[0]] + frames)
            logs.append([])
            tracker.filter_hook = partial(recording, scorer=tracker.scorer, log=logs[-1])
            result = tracker.run(out_dir / n, progress=progress)
        runs[n] = (tracker, result, [fastest(steps) for steps in zip(*logs)])
    load.append(os.getloadavg()[0])
    rows, frame_rows = [], []
    for n, (tracker, result, log) in runs.items():
        fr = _frame_rows(n, tracker, result, log, references, out_dir / n / "joints_mean.csv")
        frame_rows += fr
        rows.append(_filter_row(n, tracker.filter, result.run, fr, references, init_evals, repeat))
    tracker, result, _ = runs[names[0]]
    for label, params, fr in _baselines(references, frames, result.joints[0], tracker.up_axis,
                                        result.run["height_m"]):
        frame_rows += fr
        rows.append({"filter": label, "params": params, **{
            k: _mean(r.get(k) for r in fr) for k in fr[0] if k.endswith(("_mm_best", "_mm_mean"))}})
    if peer_seconds is not None:
        rows.append({"filter": "bodytrack (peer)", "params": "its own figure (measured elsewhere)",
                     "s_per_frame": float(peer_seconds)})
    doc = {"dataset": str(dataset.path), "cameras": [c.name for c in dataset.cameras],
           "frames": frames, "filters": names, "budget": budget,
           "initial_pose": "given" if settings.init_pose is not None else "automatic, run once",
           "repeat": repeat, "init_evaluations": init_evals,
           "init_weight": result.run["per_frame"][0]["weight"],
           "resolution": settings.resolution, "seed": settings.seed,
           "device_kind": jax.devices()[0].device_kind, "load_average_1min": load,
           "references": [{"label": r.label, "path": r.path} for r in references],
           "rows": [{k: _finite(v) for k, v in r.items()} for r in rows],
           "frame_rows": [{k: _finite(v) for k, v in r.items()} for r in frame_rows]}
    files = write_outputs(out_dir, doc)
    return CompareResult(rows, frame_rows, doc, files)


def _frame_rows(name: str, tracker: Tracker, result, log: list[StepLog], references,
                mean_csv: Path) -> list[dict]:
    """One row per compared frame of a run (its steps, in order); writes the mean estimates'
    joints to ``mean_csv`` (joints.csv convention, nan rows where the frame is missing)."""
    shape = tracker.base_shape.scaled_to(result.run["height_m"])
    steps = iter(log)
    rows = []
    means = CsvAppender(mean_csv, JOINT_COLUMNS)
    try:
        for rec in result.run["per_frame"][1:]:  # the first row is the shared initial pose
            row = {"filter": name, "frame": rec["frame"], "status": rec["status"], "weight": rec["weight"]}
            pts = [np.full((len(POINT_NAMES), 3), np.nan)] * 2
            if rec["status"] == "tracked":
                s = next(steps)
                pts = [forward_kinematics(q, shape.values, tracker.U).points
                       for q in (s.info.best, s.info.mean)]
                row.update(evaluations=s.evaluations, seconds=s.seconds, cpu_seconds=s.cpu_seconds,
                           likelihood_seconds=s.likelihood_seconds)
                for ref in references:
                    d = _distances(ref, rec["frame"], *pts)
                    row.update({f"{ref.label}_mm_best": 1000 * d[0], f"{ref.label}_mm_mean": 1000 * d[1]})
            means.write(rec["frame"], rec["time_s"], pts[1].ravel())
            rows.append(row)
    finally:
        means.close()
    return rows


def _baselines(references, frames, init_points, up_axis: str, height: float):
    """(label, params, per-frame rows) that put the distances in scale: the shared initial pose
    held still, and for a bodytrack peer our body fitted to its joints (the closest our model
    can come to them: the two bodies differ in proportions and joint placement)."""
    from .bodytrack import fit_our_pose

    if not references:
        return []
    held = []
    for f in frames:
        row = {"filter": "initial pose (held)", "frame": f}
        for ref in references:
            d = _distances(ref, f, init_points, init_points)
            row.update({f"{ref.label}_mm_best": 1000 * d[0], f"{ref.label}_mm_mean": 1000 * d[1]})
        held.append(row)
    out = [("initial pose (held)", "no filtering", held)]
    for ref in (r for r in references if r.label == "peer"):
        fitted = []
        for f in (f for f in frames if f in ref.frames):
            target = ref.points[list(ref.frames).index(f)]
            fit = fit_our_pose(dict(zip(ref.names, target)), up=up_axis, height_m=height)
            d = _distances(ref, f, fit.points, fit.points)
            fitted.append({"filter": "our model fitted to the peer", "frame": f,
                           "peer_mm_best": 1000 * d[0], "peer_mm_mean": 1000 * d[1]})
        if fitted:
            out.append(("our model fitted to the peer", "least squares, same height", fitted))
    return out


def _mean(values, average=np.mean) -> float:
    v = [x for x in values if x is not None and np.isfinite(x)]
    return float(average(v)) if v else float("nan")


def _filter_row(name: str, f: Filter, run: dict, fr: list[dict], references, init_evals: int,
                repeat: int) -> dict:
    tracked = [r for r in fr if r["status"] == "tracked"]
    # a single run's first step pays the JIT compilation, and a later one may when the ROI bucket
    # grows: the median of the other steps is the steady cost (repeated runs time every step warm)
    warm = tracked if repeat > 1 else (tracked[1:] or tracked)
    seconds = _mean((r["seconds"] for r in warm), np.median)
    row = {"filter": name,
           "params": " ".join(f"{k}={v}" for k, v in f.params.items() if k != "interesting"),
           "evaluations_per_frame": run["evaluations_per_frame"],
           "measured_evaluations_per_frame": _mean(r["evaluations"] for r in tracked),
           "init_evaluations": init_evals, "frames": len(tracked),
           "s_per_frame": seconds, "first_step_s": tracked[0]["seconds"] if tracked else float("nan"),
           "cpu_s_per_frame": _mean((r["cpu_seconds"] for r in warm), np.median),
           "likelihood_s_per_frame": _mean((r["likelihood_seconds"] for r in warm), np.median),
           "evaluations_per_s": run["evaluations_per_frame"] / seconds if seconds > 0 else float("nan"),
           "final_weight": tracked[-1]["weight"] if tracked else float("nan"),
           "mean_weight": _mean(r["weight"] for r in tracked)}
    for ref in references:
        for est in ("best", "mean"):
            row[f"{ref.label}_mm_{est}"] = _mean(r.get(f"{ref.label}_mm_{est}") for r in tracked)
    return row


# -- outputs -------------------------------------------------------------------------------------
COLUMNS = {  # compare.md headers
    "filter": "filter", "evaluations_per_frame": "evaluations / frame", "s_per_frame": "s / frame",
    "cpu_s_per_frame": "CPU s / frame", "evaluations_per_s": "evaluations / s",
    "final_weight": "final weight", "truth_mm_best": "to truth, best (mm)",
    "truth_mm_mean": "to truth, mean (mm)", "peer_mm_best": "to peer, best (mm)",
    "peer_mm_mean": "to peer, mean (mm)",
}


def _fmt(v) -> str:
    if v is None or (isinstance(v, float) and not np.isfinite(v)):
        return ""
    if isinstance(v, float):
        return f"{v:.4g}" if abs(v) < 100 else f"{v:.0f}"
    return str(v)


def markdown_table(rows: list[dict], columns: Sequence[str]) -> str:
    cols = [c for c in columns if any(c in r for r in rows)]
    lines = ["| " + " | ".join(COLUMNS.get(c, c) for c in cols) + " |", "|" + "---|" * len(cols)]
    lines += ["| " + " | ".join(_fmt(r.get(c)) for c in cols) + " |" for r in rows]
    return "\n".join(lines)


def _finite(v):
    """NaN -> None (empty CSV cell, JSON null); everything else unchanged."""
    return None if isinstance(v, float) and not np.isfinite(v) else v


def _write_csv(path: Path, rows: list[dict]) -> None:
    cols = list(dict.fromkeys(k for r in rows for k in r))
    with open(path, "w", newline="") as fh:
        w = csv.DictWriter(fh, cols)
        w.writeheader()
        w.writerows({k: _finite(v) for k, v in r.items()} for r in rows)


def write_outputs(out_dir: Path, doc: dict) -> list[Path]:
    """compare.csv, compare_frames.csv, compare.md, compare.json and compare.png into ``out_dir``."""
    rows, frame_rows = doc["rows"], doc["frame_rows"]
    _write_csv(out_dir / "compare.csv", rows)
    _write_csv(out_dir / "compare_frames.csv", frame_rows)
    write_json_atomic(out_dir / "compare.json", doc)
    per_frame_cols = ["filter", "frame", "weight", "evaluations", "seconds"] + [
        c for c in COLUMNS if c.endswith(("_best", "_mean"))]
    md = [f"# Filters compared on {Path(doc['dataset']).name}", "",
          f"{len(doc['cameras'])} cameras, frames {doc['frames'][0]}..{doc['frames'][-1]} "
          f"({len(doc['frames'])}), budget {doc['budget']} likelihood evaluations per frame, "
          f"scoring resolution {doc['resolution']} px, seed {doc['seed']}, initial pose "
          f"{doc['initial_pose']} ({doc['init_evaluations']} likelihood evaluation(s), shared; weight "
          f"{_fmt(doc['init_weight'])} on frame {doc['frames'][0]}), "
          f"device {doc['device_kind']}, 1-min load average {doc['load_average_1min'][0]:.1f} -> "
          f"{doc['load_average_1min'][1]:.1f}.", "",
          markdown_table(rows, list(COLUMNS)), "", "Per frame:", "",
          markdown_table(frame_rows, per_frame_cols), "",
          "s / frame: wall time of the filter step (likelihood included), median over the steps "
          + ("(each the fastest of its repeats)" if doc["repeat"] > 1 else
             "after the first (which pays the JIT compilation)")
          + "; CPU s: the process's CPU time (all threads) over the same steps. Distances: mean 3D "
          "distance of the shared limb joints, for the heaviest particle (`best`, what joints.csv "
          "holds) and the weighted mean (`mean`)."]
    (out_dir / "compare.md").write_text("\n".join(md) + "\n")
    files = [out_dir / f for f in ("compare.csv", "compare_frames.csv", "compare.md", "compare.json")]
    return files + [plot(doc, out_dir / "compare.png")]


def plot(doc: dict, path: Path) -> Path:
    """Four bar panels: s/frame, evaluations/s, final weight, joint distances."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    ours = [r for r in doc["rows"] if r["filter"] in doc["filters"]]
    others = [r for r in doc["rows"] if r["filter"] not in doc["filters"]]
    names = [r["filter"] for r in ours]
    x = np.arange(len(names))

    def values(key):
        return [np.nan if r.get(key) is None else r[key] for r in ours]

    fig = Figure(figsize=(8, 5.5), dpi=80)
    FigureCanvasAgg(fig)
    axes = fig.subplots(2, 2).ravel()
    axes[0].bar(x - 0.2, values("s_per_frame"), 0.4, color="tab:blue", label="wall")
    axes[0].bar(x + 0.2, values("cpu_s_per_frame"), 0.4, color="tab:cyan", label="CPU")
    for ax, key, title in zip(axes, (None, "evaluations_per_s", "final_weight"),
                              ("seconds per frame", "likelihood evaluations per second (wall)",
                               "best weight, last frame")):
        if key:
            ax.bar(x, values(key), color="tab:blue")
        ax.set_xticks(x, names)
        ax.set_title(title, fontsize=10)
    dist = [k for k in ours[0] if k.endswith(("_mm_best", "_mm_mean"))] if ours else []
    width = 0.8 / max(len(dist), 1)
    for i, key in enumerate(dist):
        axes[3].bar(x + (i - (len(dist) - 1) / 2) * width, values(key), width,
                    label=key.replace("_mm_", ", "))
    axes[3].set_xticks(x, names)
    axes[3].set_title("mean limb-joint distance (mm)" if dist else "no reference given", fontsize=10)
    styles = iter(["--", ":", "-."] * 4)
    for r in others:  # the peer's time, and the distance baselines, as lines
        ax, key = (axes[0], "s_per_frame") if "s_per_frame" in r else (axes[3], next(
            (k for k in dist if r.get(k) is not None), None))
        if key is not None:
            ax.axhline(r[key], color="tab:red", ls=next(styles), label=f"{r['filter']}")
    for ax in (axes[0], axes[3]):
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=7)
    fig.suptitle(f"{Path(doc['dataset']).name}: budget {doc['budget']} evaluations / frame", fontsize=11)
    fig.tight_layout()
    fig.savefig(path)
    return path


# -- command line ----------------------------------------------------------------------------------
