"""Scoring an estimated joint trajectory against a reference: MPJPE per joint, per frame, per axis.

Which joints are scored: the 12 limb joints (:data:`ipf_jax.body.model.LIMB_JOINTS`) when both
tables have them, because hips, knees, ankles, shoulders, elbows and wrists mean the same point in
every motion-capture convention, while sacrum, toes and head do not; otherwise every name the two
share; or the caller's list. Per-joint errors are reported for every shared name.

A frame is scored when every scored joint is finite in the estimate and in the interpolated
reference (missing tracker frames are nan rows); frames outside the reference's time range are
left out and counted.

**Systematic and random error** (how gait-lab validations report a marker-less system): per joint,
the *constant offset* is the mean error vector over the scored frames (a template body whose hips
sit 8 cm low, say) and the *offset-free error* is the mean distance once that vector is removed
(what no constant correction can fix: jitter, lag, wrong frames). ``mpjpe_offset_free_m`` averages
the latter over the scored joints and frames, ``mean_offset_m`` the offsets' lengths.

**Lost and recovered frames**: a frame is *lost* when its mean error over the scored joints is
above :data:`LOST_M` and *recovered* when it is back under :data:`RECOVERED_M`
(:func:`loss_summary`).
"""
from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

import numpy as np

from ...body.model import LIMB_JOINTS
from ...data.runfiles import JointsTable, read_joints_csv
from ...errors import IPFError, require
from .align import apply_rigid, resample, rigid_fit

ALIGN_MODES = ("none", "rigid")
LOST_M = 0.200  # a frame whose mean scored-joint error is above this is lost...
RECOVERED_M = 0.100  # ...and it is recovered once back under this
LEG_JOINTS = tuple(j for j in LIMB_JOINTS if j.endswith(("hip", "knee", "ankle")))


class JointSplit(NamedTuple):
    """Per scored joint: the constant offset and what is left (metres).

    offset : (S, 3) mean error vector;  offset_m : (S,) its length;
    offset_free_m : (S,) mean distance after removing the offset;  mpjpe_m : (S,) mean distance.
    """

    names: tuple[str, ...]
    offset: np.ndarray
    offset_m: np.ndarray
    offset_free_m: np.ndarray
    mpjpe_m: np.ndarray


def split_offsets(diff: np.ndarray, names: tuple[str, ...]) -> JointSplit:
    """diff : (F, S, 3) estimate - truth over F scored frames -> :class:`JointSplit`."""
    offset = diff.mean(0)  # (S, 3)
    return JointSplit(tuple(names), offset, np.linalg.norm(offset, axis=-1),
                      np.linalg.norm(diff - offset, axis=-1).mean(0),
                      np.linalg.norm(diff, axis=-1).mean(0))


def loss_summary(frame_error: np.ndarray, *, lost_m: float = LOST_M,
                 recovered_m: float = RECOVERED_M) -> dict:
    """frame_error : (F,) mean error per scored frame, in time order -> lost/recovered counts.

    ``longest_lost_run``: most consecutive lost frames; ``recoveries``: for each entry into loss,
    the frames until the error is back under ``recovered_m`` (None when it never is).
    """
    e = np.asarray(frame_error, float)
    lost = e > lost_m
    runs, recoveries = [], []
    i = 0
    while i < len(e):
        if lost[i]:
            j = i
            while j < len(e) and lost[j]:
                j += 1
            runs.append(j - i)
            k = next((k for k in range(i, len(e)) if e[k] < recovered_m), None)
            recoveries.append(None if k is None else int(k - i))
            i = j
        else:
            i += 1
    worst = np.sort(e)[::-1][:5]
    return {"lost_frames": int(lost.sum()), "longest_lost_run": int(max(runs, default=0)),
            "recoveries_frames": recoveries, "worst5_mean_m": round(float(worst.mean()), 6)
            if len(worst) else None, "lost_m": lost_m, "recovered_m": recovered_m}


class Evaluation(NamedTuple):
    """Result of :func:`evaluate`. K shared names, T estimate frames."""

    names: tuple[str, ...]  # (K,) names present in both tables
    scored: tuple[str, ...]  # the names the MPJPE averages over
    frame: np.ndarray  # (T,) estimate frame numbers
    time_s: np.ndarray  # (T,)
    estimate: np.ndarray  # (T, K, 3) after alignment
    truth: np.ndarray  # (T, K, 3) reference interpolated at time_s
    errors: np.ndarray  # (T, K) Euclidean error, metres (nan where not computable)
    scored_frames: np.ndarray  # (T,) bool
    inside: np.ndarray  # (T,) bool: time_s within the reference's time range
    mpjpe_m: float
    per_joint_m: dict
    rms_axis_m: dict
    align: dict
    split: JointSplit  # constant offset and offset-free error of each scored joint


def choose_joints(estimate_names, truth_names, joints=None, *, path=None) -> tuple[tuple, tuple]:
    """(shared names in estimate order, scored names); raises IPFError for an unusable choice."""
    shared = tuple(n for n in estimate_names if n in set(truth_names))
    require(bool(shared), "the estimate and the truth share no point name", path)
    if joints:
        unknown = [j for j in joints if j not in shared]
        require(not unknown, f"--joints names {', '.join(unknown)} not in both files "
                f"(shared: {', '.join(shared)})", path)
        return shared, tuple(dict.fromkeys(joints))
    if all(j in shared for j in LIMB_JOINTS):
        return shared, LIMB_JOINTS
    return shared, shared


def evaluate(estimate: JointsTable, truth: JointsTable, *, joints=None, align: str = "none",
             estimate_path=None, truth_path=None) -> Evaluation:
    """Score ``estimate`` against ``truth`` (see module doc).

    Parameters
    ----------
    estimate, truth : tables in the joints.csv convention (:func:`ipf_jax.data.runfiles.read_joints_csv`);
        their frame rates may differ, ``time_s`` is the common clock.
    joints : names to score (default: the 12 limb joints when both have them, else all shared).
    align : ``none``, or ``rigid`` for one rotation + translation fitted over all scored points.
    estimate_path, truth_path : files named in errors.
    """
    require(align in ALIGN_MODES, f"unknown alignment {align!r} (choose {', '.join(ALIGN_MODES)})")
    names, scored = choose_joints(estimate.names, truth.names, joints, path=estimate_path)
    stuck = np.flatnonzero(np.diff(np.asarray(estimate.time_s, float)) <= 0)
    first = int(stuck[0]) + 1 if len(stuck) else 0
    require(not len(stuck), f"time_s must increase strictly from row to row (rows {first} and "
            f"{first + 1} do not; written with a wrong frame rate?)", estimate_path)
    est = estimate.points[:, [estimate.names.index(n) for n in names]]  # (T, K, 3)
    ref, inside = resample(estimate.time_s, truth.time_s,
                           truth.points[:, [truth.names.index(n) for n in names]], path=truth_path)
    s_idx = [names.index(n) for n in scored]
    finite = np.isfinite(est).all(-1) & np.isfinite(ref).all(-1)  # (T, K)
    scored_frames = inside & finite[:, s_idx].all(1)
    if not scored_frames.any():
        raise IPFError(f"no frame to score: {int(inside.sum())} of {len(inside)} estimate frames lie in "
                       f"the truth's time range {truth.time_s[0]:.3f}..{truth.time_s[-1]:.3f} s, and "
                       "none has every scored joint in both files", estimate_path)
    info = {"mode": align}
    if align == "rigid":
        src = est[scored_frames][:, s_idx].reshape(-1, 3)
        dst = ref[scored_frames][:, s_idx].reshape(-1, 3)
        rot, shift = rigid_fit(src, dst)
        est = apply_rigid(est, rot, shift)
        info.update(rotation=rot.round(9).tolist(), translation_m=shift.round(9).tolist(),
                    note="one rotation and translation (no scale) fitted over every scored frame "
                         "and joint, applied to the estimate before scoring")
    diff = est - ref  # (T, K, 3)
    errors = np.linalg.norm(diff, axis=-1)
    scored_diff = diff[scored_frames][:, s_idx]  # (F, S, 3)
    per_joint = {}
    for k, n in enumerate(names):
        ok = inside & finite[:, k]
        per_joint[n] = float(errors[ok, k].mean()) if ok.any() else None
    rms = np.sqrt(np.mean(scored_diff ** 2, axis=(0, 1)))
    return Evaluation(
        names=names, scored=scored, frame=np.asarray(estimate.frame), time_s=np.asarray(estimate.time_s),
        estimate=est, truth=ref, errors=errors, scored_frames=scored_frames, inside=inside,
        mpjpe_m=float(np.linalg.norm(scored_diff, axis=-1).mean()), per_joint_m=per_joint,
        rms_axis_m=dict(zip("xyz", map(float, rms))), align=info,
        split=split_offsets(scored_diff, scored))


def evaluate_files(estimate_path: str | Path, truth_path: str | Path, *, joints=None,
                   align: str = "none") -> tuple[Evaluation, JointsTable, JointsTable]:
    """Read both joints.csv-convention files and :func:`evaluate` them; returns the tables too."""
    est = read_joints_csv(estimate_path)
    ref = read_joints_csv(truth_path)
    return (evaluate(est, ref, joints=joints, align=align, estimate_path=estimate_path,
                     truth_path=truth_path), est, ref)


def frame_errors(ev: Evaluation) -> np.ndarray:
    """(F,) mean error over the scored joints of each scored frame, in time order."""
    s_idx = [ev.names.index(n) for n in ev.scored]
    return ev.errors[ev.scored_frames][:, s_idx].mean(1)


def systematic_doc(ev: Evaluation) -> dict:
    """``eval.json`` -> ``systematic``: offsets and offset-free errors (see module doc)."""
    sp = ev.split
    legs = [k for k, n in enumerate(sp.names) if n in LEG_JOINTS]
    r = lambda v: round(float(v), 6)  # noqa: E731
    diff_free = np.stack([ev.estimate[ev.scored_frames][:, ev.names.index(n)]
                          - ev.truth[ev.scored_frames][:, ev.names.index(n)] - sp.offset[k]
                          for k, n in enumerate(sp.names)], 1)  # (F, S, 3)
    return {
        "mpjpe_offset_free_m": r(np.linalg.norm(diff_free, axis=-1).mean()),
        "mean_offset_m": r(sp.offset_m.mean()),
        "mean_leg_offset_m": r(sp.offset_m[legs].mean()) if legs else None,
        "per_joint": {n: {"offset_xyz_m": [r(v) for v in sp.offset[k]], "offset_m": r(sp.offset_m[k]),
                          "offset_free_m": r(sp.offset_free_m[k]), "mpjpe_m": r(sp.mpjpe_m[k])}
                      for k, n in enumerate(sp.names)},
        "note": "offset = mean error vector of a joint over the scored frames; offset-free = mean "
                "distance once it is removed",
    }


def summary_doc(ev: Evaluation) -> dict:
    """The ``eval.json`` document (metres; see docs/evaluation.md)."""
    return {
        "mpjpe_m": round(ev.mpjpe_m, 6),
        "systematic": systematic_doc(ev),
        "loss": loss_summary(frame_errors(ev)),
        "per_joint_m": {k: None if v is None else round(v, 6) for k, v in ev.per_joint_m.items()},
        "rms_axis_m": {k: round(v, 6) for k, v in ev.rms_axis_m.items()},
        "n_frames": int(ev.scored_frames.sum()),
        "n_frames_estimate": len(ev.frame),
        "n_frames_outside_truth": int((~ev.inside).sum()),
        "n_frames_incomplete": int((ev.inside & ~ev.scored_frames).sum()),
        "scored_joints": list(ev.scored),
        "shared_joints": list(ev.names),
        "align": ev.align,
        "time_alignment": "truth linearly interpolated at the estimate's time_s",
        "units": "m",
    }
