"""Offline reprocessing in two passes: track, re-fit the shape on many tracked frames, track again.

    pass 1  ipf_jax.tracking.tracker.track into OUT/pass1/ (shape calibrated at the start, as in one pass)
    refit   ipf_jax.tracking.shape_fit.refit_from_track on ShapeFitSettings.refit_frames tracked frames,
            seeded by pass 1's poses and shape
    pass 2  ipf_jax.tracking.tracker.track into OUT/ with that shape held (a shape file, no shape search),
            started from the refit pose of the first tracked frame (no second initialisation)

``OUT/run.json`` is pass 2's, with ``passes`` (each pass's evaluations and seconds) and
``shape_fit`` (both fits' records and their summed cost) added; ``OUT/shape.json`` is the shape
of pass 2 with both fit records. Pass 1's files stay in ``OUT/pass1/``. ``resume`` resumes
whichever pass was interrupted (the refit is deterministic, so it is simply run again).
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from ..body.shape import shape_from_json
from ..data import checkpoint
from ..data.dataset import Dataset
from ..data.runfiles import write_json_atomic
from ..errors import require
from .shape_fit import refit_from_track, shape_doc
from .tracker import RunResult, Tracker, TrackSettings
from .tracker import track as track_one

TRACKED = ("init", "tracked", "reinit", "reinit-rejected")


def _pass_summary(run: dict) -> dict:
    tracked = [r for r in run["per_frame"] if r["status"] != "missing"]
    return {"init_evaluations": run["init_evaluations"],
            "tracking_evaluations": int(sum(r.get("evaluations") or 0 for r in tracked)),
            "shape_fit_evaluations": run.get("shape_fit_evaluations", 0),
            "seconds": run["seconds"]["total"],
            "per_tracked_frame_s": run["seconds"]["per_tracked_frame_mean"]}


def track(dataset: Dataset, out_dir: str | Path, settings: TrackSettings = TrackSettings(), *,
          frames: list[int] | None = None, resume: bool = False, progress: bool = True,
          frame_hook=None) -> RunResult:
    """Track ``dataset`` into ``out_dir`` in ``settings.passes`` passes: one
    (:func:`ipf_jax.tracking.tracker.track`) or two (module doc). ``frame_hook`` sees the last
    pass's frames."""
    passes = settings.passes
    require(passes in (1, 2), f"passes must be 1 or 2 (got {passes})")
    if passes == 1:
        return track_one(dataset, out_dir, settings, frames=frames, resume=resume, progress=progress,
                         frame_hook=frame_hook)
    require(settings.shape_file is None, "--passes 2 re-fits the shape: it cannot be used with --shape")
    out = Path(out_dir)
    first_dir = out / "pass1"
    first_dir.mkdir(parents=True, exist_ok=True)
    settings = settings._replace(passes=1)
    r1 = track_one(dataset, first_dir, settings, frames=frames, resume=_resumable(first_dir, resume),
                   progress=progress)
    t0 = time.perf_counter()
    tracked = {int(rec["frame"]): pose for rec, pose in zip(r1.run["per_frame"], r1.poses)
               if rec["status"] in TRACKED and np.all(np.isfinite(pose))}
    require(len(tracked) > 0, "pass 1 tracked no frame: nothing to re-fit the shape on", out)
    shape1 = shape_from_json(r1.run["shape"])
    tr = Tracker(dataset, settings, frames)
    fit = refit_from_track(tr.fit_scene(), tracked, shape1, height_m=tr.settings.height_m,
                           settings=settings.shape_fit, seed=settings.seed)
    refit_seconds = time.perf_counter() - t0
    shape_path = first_dir / "shape_refit.json"
    write_json_atomic(shape_path, shape_doc(fit.shape, "re-fitted on pass 1's track (ipf_jax.tracking.shape_fit)", fit.doc))
    first = min(tracked)
    start = fit.frames[[fr.frame for fr in fit.frames].index(first)].particles[0] \
        if first in [fr.frame for fr in fit.frames] else tracked[first]
    settings2 = settings._replace(shape_file=str(shape_path), init_pose=np.asarray(start, float),
                                  height_m=settings.height_m)
    r2 = track_one(dataset, out, settings2, frames=frames, resume=_resumable(out, resume), progress=progress,
                   frame_hook=frame_hook)
    run = dict(r2.run)
    fit1 = r1.run.get("shape_fit") or {}
    fit2 = dict(fit.doc, seconds=round(refit_seconds, 3))
    run["passes"] = [{"pass": 1, **_pass_summary(r1.run)}, {"pass": 2, **_pass_summary(r2.run)}]
    run["shape_fit"] = {"evaluations": int(fit1.get("evaluations", 0) + fit2["evaluations"]),
                        "seconds": round(float(fit1.get("seconds", 0.0) + fit2["seconds"]), 3),
                        "pass1": fit1 or None, "pass2": fit2}
    run["shape_fit_evaluations"] = run["shape_fit"]["evaluations"]
    run["shape_source"] = "fitted in two passes (ipf_jax.tracking.shape_fit, ipf_jax.tracking.passes)"
    write_json_atomic(out / "run.json", run)
    write_json_atomic(out / "shape.json", shape_doc(fit.shape, run["shape_source"], run["shape_fit"]))
    return r2._replace(run=run)


def _resumable(folder: Path, resume: bool) -> bool:
    """Resume a pass only where it left a checkpoint (an absent pass starts anew)."""
    return bool(resume) and (folder / checkpoint.NAME).exists()
