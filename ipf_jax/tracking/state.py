"""What a tracking run carries from one frame to the next (:class:`TrackState`), which is also its
checkpoint, and what one frame produces (:class:`FrameRecord`).

A checkpoint (``DIR/checkpoint.npz``, :mod:`ipf_jax.data.checkpoint`) is the state as it stood
after its last frame: the filter's particles and weights as arrays, the rest as JSON, and the key
of the settings it was started with. Per-frame random keys are derived from (seed, frame), so a
resumed run draws the same noise as an uninterrupted one and writes byte-identical CSVs.
"""
from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

import numpy as np

from ..body.shape import BodyShape, shape_from_json
from ..data import checkpoint
from ..data.runfiles import EncodedList
from ..errors import IPFError
from ..filters.base import FilterState
from .origin import FrameAnchor

#: Before the first frame the plane a single camera's rays are cut with sits at about the pelvis;
#: the initialisation replaces it by the body's own sacrum height (see :mod:`.origin`).
START_ANCHOR_HEIGHT_M = 0.9
HISTORY = 10  # frames of best weights the confidence is measured against (their median)


class TrackState(NamedTuple):
    """Everything a run carries from frame to frame (immutable; ``_replace`` makes the next one).

    next_index : index into the run's frame list of the next frame to track.
    rows : rows written to joints.csv and poses.csv.
    filter : the filter's particles (N, D) and weights (N,); None until initialised.
    shape : the subject found at initialisation (None before).
    history : best weights of the last :data:`HISTORY` frames; low_streak : frames in a row of low
        confidence.
    anchor : the last frame's silhouette anchor (body origin); anchor_height : the plane a single
        camera's rays are cut with.
    init_evaluations : likelihood evaluations spent initialising and recovering.
    reinits : frames where a re-initialisation was tried.  records : run.json's ``per_frame`` so far.
    shape_fit : the record of the shape calibration at the start (:mod:`.shape_fit`), or None.
    bad_streak : frames in a row failing the absolute loss test (:mod:`.loss`).
    last_good : (D,) the estimate of the last frame that passed it (None before).
    last_attempt : ``next_index`` of the last recovery attempt.
    recoveries : one record per recovery attempt (frame, trigger, stage, accepted, evaluations).
    explained_levels : per camera, the loss test's explained level set on the first frame
        (:func:`.loss.clutter_levels`); None before.
    """

    next_index: int = 0
    rows: int = 0
    filter: FilterState | None = None
    shape: BodyShape | None = None
    history: tuple[float, ...] = ()
    low_streak: int = 0
    anchor: FrameAnchor | None = None
    anchor_height: float = START_ANCHOR_HEIGHT_M
    init_evaluations: int = 0
    reinits: tuple[int, ...] = ()
    records: tuple[dict, ...] = ()
    shape_fit: dict | None = None
    bad_streak: int = 0
    last_good: np.ndarray | None = None
    last_attempt: int = -(1 << 30)
    recoveries: tuple[dict, ...] = ()
    explained_levels: tuple[float, ...] | None = None


class FrameRecord(NamedTuple):
    """What one frame produced: its row of ``poses.csv`` (D,) and of ``joints.csv`` (J, 3) (NaN
    when the frame is missing) and its ``run.json`` record (status, weight, confidence, ...)."""

    frame: int
    time_s: float
    pose: np.ndarray
    points: np.ndarray
    info: dict


def save(out_dir: Path, state: TrackState, settings_key: str,
         records: EncodedList | None = None) -> None:
    """Write ``state`` as the run's checkpoint (atomically); ``records``: its records already
    encoded (:class:`~ipf_jax.data.runfiles.EncodedList`), kept from one checkpoint to the next."""
    meta = {"next_index": state.next_index, "rows": state.rows,
            "shape": None if state.shape is None else state.shape.to_json(),
            "history": list(state.history), "low_streak": state.low_streak,
            "per_frame": list(state.records) if records is None else records.update(state.records),
            "reinits": list(state.reinits),
            "init_evaluations": state.init_evaluations, "settings_key": settings_key,
            "anchor": None if state.anchor is None else state.anchor.to_json(),
            "anchor_height": state.anchor_height, "shape_fit": state.shape_fit,
            "bad_streak": state.bad_streak, "last_attempt": state.last_attempt,
            "recoveries": list(state.recoveries),
            "explained_levels": None if state.explained_levels is None else list(state.explained_levels)}
    arrays = {} if state.filter is None else {"particles": state.filter.particles,
                                              "weights": state.filter.weights}
    if state.last_good is not None:
        arrays["last_good"] = state.last_good
    checkpoint.save(out_dir, meta, arrays)


def load(out_dir: Path) -> tuple[TrackState, str]:
    """The state a checkpoint holds and the key of the settings it was made with."""
    meta, arrays, path = checkpoint.load(out_dir)
    try:
        filt = FilterState(arrays["particles"], arrays["weights"]) if "particles" in arrays else None
        state = TrackState(
            next_index=meta["next_index"], rows=meta["rows"], filter=filt,
            shape=None if meta["shape"] is None else shape_from_json(meta["shape"]),
            history=tuple(meta["history"]), low_streak=meta["low_streak"],
            anchor=FrameAnchor.from_json(meta["anchor"]), anchor_height=meta["anchor_height"],
            init_evaluations=meta["init_evaluations"], reinits=tuple(meta["reinits"]),
            records=tuple(meta["per_frame"]), shape_fit=meta.get("shape_fit"),
            bad_streak=meta["bad_streak"], last_good=arrays.get("last_good"),
            last_attempt=meta["last_attempt"], recoveries=tuple(meta["recoveries"]),
            explained_levels=None if meta["explained_levels"] is None else tuple(meta["explained_levels"]))
        return state, meta["settings_key"]
    except KeyError as e:  # written by another version of ipf-jax
        raise IPFError(f"checkpoint from another ipf-jax version (no {e}): rerun without --resume",
                       path) from None
