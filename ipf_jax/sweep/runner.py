"""Run one spec (sweep cell or batch item): track the dataset, score it when there is a truth.

:func:`execute` never raises for a problem of the cell itself: a user error (IPFError) or a bug
(any other exception) becomes a ``failed`` record with the error, so one bad cell cannot stop a
sweep. Only an interruption (KeyboardInterrupt, SystemExit) escapes.

The record separates what must be identical wherever the cell runs (``result``: evaluations,
frames, MPJPE, a hash of joints.csv) from what depends on the machine (``timing``, ``host``).
"""
from __future__ import annotations

import hashlib
import os
import shutil
import socket
import time
import traceback
from pathlib import Path

import numpy as np

from ..data.checkpoint import NAME as CHECKPOINT
from ..data.runfiles import read_joints_csv
from ..errors import IPFError, require
from ..jax_setup import release_compiled


def _run_summary(run: dict, joints_csv: Path) -> tuple[dict, dict]:
    per_frame = run["per_frame"]
    init = [r["seconds"] for r in per_frame if r["status"] == "init"]
    tracked = [r["seconds"] for r in per_frame if r["status"] == "tracked"]
    result = {
        "filter_params": run["filter_params"],
        "evaluations_per_frame": run["evaluations_per_frame"],
        "init_evaluations": run["init_evaluations"],
        "frames_done": run["frames"]["done"], "frames_missing": run["frames"]["missing"],
        "reinitialisations": run["reinitialisations"], "height_m": run["height_m"],
        "joints_sha256": hashlib.sha256(joints_csv.read_bytes()).hexdigest(),
    }
    # the median ignores the few frames that compile a new image-window shape (seconds each)
    timing = {"seconds_per_frame": run["seconds"]["per_tracked_frame_mean"],
              "seconds_per_frame_median": round(float(np.median(tracked)), 4) if tracked else None,
              "seconds_total": run["seconds"]["total"], "init_seconds": init[0] if init else None}
    return result, timing


def code_fingerprint() -> str:
    """16 hex digits of a SHA-256 over the ipf_jax package's .py and .json files as they are now.

    Read per cell, not per process: a file edited while a sweep runs (a preset, a module not yet
    imported) changes the results of the cells after it, and resuming after an update mixes
    versions. The records keep it so that :func:`ipf_jax.sweep.summary.write_status` can say so.
    """
    root = Path(__file__).resolve().parent.parent
    digest = hashlib.sha256()
    for f in sorted(p for p in root.rglob("*") if p.suffix in (".py", ".json") and "__pycache__" not in p.parts):
        digest.update(str(f.relative_to(root)).encode() + b"\0" + f.read_bytes() + b"\0")
    return digest.hexdigest()[:16]


def _failure(e: BaseException) -> dict:
    if isinstance(e, IPFError):
        return {"type": "IPFError", "message": str(e)}
    tb = traceback.format_exception(type(e), e, e.__traceback__)
    return {"type": type(e).__name__, "message": str(e) or type(e).__name__,
            "traceback": "".join(tb[-4:])}


def execute(spec: dict, work_dir: str | Path) -> dict:
    """Track ``spec`` into ``work_dir`` (emptied first) and evaluate it; returns the cell record.

    Record keys: ``status`` (ok | failed), ``result``, ``timing``, ``error`` (None or type,
    message[, traceback]), ``code`` (:func:`code_fingerprint`), ``host`` (hostname, pid, wall s).
    """
    from ..analysis.evaluation import evaluate_files, summary_doc, write_outputs
    from ..data.dataset import open_dataset
    from ..data.frames import parse_frames, select_frames
    from ..tracking.passes import track
    from .spec import track_settings

    work_dir = Path(work_dir)
    t0 = time.perf_counter()
    record = {"status": "ok", "result": None, "timing": None, "error": None, "code": code_fingerprint()}
    try:
        if work_dir.exists():  # a cell interrupted earlier restarts from its first frame
            shutil.rmtree(work_dir)
        work_dir.mkdir(parents=True)
        if spec.get("truth"):  # read before hours of tracking: a missing or corrupt file fails now
            require(Path(spec["truth"]).is_file(), "truth file not found", spec["truth"])
            read_joints_csv(spec["truth"])
        ds = open_dataset(spec["dataset"])
        frames = select_frames(ds.frames, parse_frames(spec["frames"]) if spec.get("frames") else None)
        res = track(ds, work_dir, track_settings(spec), frames=frames, progress=False)
        record["result"], record["timing"] = _run_summary(res.run, work_dir / "joints.csv")
        (work_dir / CHECKPOINT).unlink(missing_ok=True)  # only useful to resume a track; this one is done
        if spec.get("truth"):
            ev, _, truth = evaluate_files(work_dir / "joints.csv", spec["truth"],
                                          joints=spec["eval"].get("joints"), align=spec["eval"]["align"])
            write_outputs(ev, truth, work_dir, plots=False, extra={"truth": spec["truth"]})
            doc = summary_doc(ev)
            record["result"].update({k: doc[k] for k in ("mpjpe_m", "per_joint_m", "rms_axis_m", "n_frames")})
    except Exception as e:  # noqa: BLE001 - failure isolation: record it, the sweep goes on
        record.update(status="failed", error=_failure(e))
    record["host"] = {"hostname": socket.gethostname(), "pid": os.getpid(),
                      "wall_seconds": round(time.perf_counter() - t0, 3)}
    # a process runs many cells (local backend, a reused Ray worker): keep clear of the map limit
    release_compiled()
    return record
