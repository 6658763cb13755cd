"""Checkpoints of the tracking loop: everything needed to continue exactly where a run stopped.

A checkpoint (``DIR/checkpoint.npz``, written atomically every K frames) holds the filter state,
the tracker's bookkeeping (confidence history, chosen height, counters) and how many rows of the
CSVs belong to it. Per-frame random keys are derived from (seed, frame), so a resumed run draws
the same noise as an uninterrupted one and writes byte-identical CSVs.
"""
from __future__ import annotations

import json
import os
import tempfile
import zipfile
from pathlib import Path
from typing import NamedTuple

import numpy as np

from ..errors import IPFError

NAME = "checkpoint.npz"


class Checkpoint(NamedTuple):
    next_index: int  # index into the run's frame list of the first frame still to do
    rows: int  # rows already in joints.csv / poses.csv
    particles: np.ndarray | None
    weights: np.ndarray | None
    shape: dict | None  # the subject's BodyShape as JSON
    history: list[float]
    low_streak: int
    per_frame: list[dict]
    reinits: list[int]
    init_evaluations: int
    settings_key: str  # the settings the run was started with (must match to resume)
    anchor: dict | None  # last frame's FrameAnchor as JSON (ipf_jax.tracking.origin)
    anchor_height: float


def save(out_dir: Path, ck: Checkpoint) -> None:
    out_dir = Path(out_dir)
    meta = {"next_index": ck.next_index, "rows": ck.rows, "shape": ck.shape,
            "history": ck.history, "low_streak": ck.low_streak, "per_frame": ck.per_frame,
            "reinits": ck.reinits, "init_evaluations": ck.init_evaluations,
            "settings_key": ck.settings_key, "anchor": ck.anchor, "anchor_height": ck.anchor_height}
    arrays = {"meta": np.frombuffer(json.dumps(meta).encode(), np.uint8)}
    if ck.particles is not None:
        arrays["particles"] = ck.particles
        arrays["weights"] = ck.weights
    fd, tmp = tempfile.mkstemp(dir=out_dir, prefix=NAME, suffix=".tmp")
    with os.fdopen(fd, "wb") as fh:
        np.savez(fh, **arrays)
        fh.flush()
        os.fsync(fh.fileno())
    os.replace(tmp, out_dir / NAME)


def load(out_dir: Path) -> Checkpoint:
    path = Path(out_dir) / NAME
    if not path.exists():
        raise IPFError("no checkpoint to resume from (run without --resume)", path)
    try:
        with np.load(path) as z:
            meta = json.loads(bytes(z["meta"]).decode())
            particles = z["particles"] if "particles" in z else None
            weights = z["weights"] if "weights" in z else None
        ck = Checkpoint(meta["next_index"], meta["rows"], particles, weights, meta["shape"],
                        meta["history"], meta["low_streak"], meta["per_frame"], meta["reinits"],
                        meta["init_evaluations"], meta["settings_key"], meta["anchor"],
                        meta["anchor_height"])
    except (OSError, ValueError, EOFError, zipfile.BadZipFile) as e:
        raise IPFError(f"corrupt checkpoint ({e})", path) from None
    except KeyError as e:  # written by another version of ipf-jax
        raise IPFError(f"checkpoint from another ipf-jax version (no {e}): rerun without --resume",
                       path) from None
    return ck
