"""Scoring an estimated joint trajectory against a reference: MPJPE per joint, per frame, per axis.

Which joints are scored: the 12 limb joints (:data:`ipf_jax.body.model.LIMB_JOINTS`) when both
tables have them, because hips, knees, ankles, shoulders, elbows and wrists mean the same point in
every motion-capture convention, while sacrum, toes and head do not; otherwise every name the two
share; or the caller's list. Per-joint errors are reported for every shared name.

A frame is scored when every scored joint is finite in the estimate and in the interpolated
reference (missing tracker frames are nan rows); frames outside the reference's time range are
left out and counted.
"""
from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

import numpy as np

from ..body.model import LIMB_JOINTS
from ..errors import IPFError, require
from ..outputs import JointsTable, read_joints_csv
from .align import apply_rigid, resample, rigid_fit

ALIGN_MODES = ("none", "rigid")


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
    estimate, truth : tables in the joints.csv convention (:func:`ipf_jax.outputs.read_joints_csv`);
        their frame rates may differ, ``time_s`` is the common clock.
    joints : names to score (default: the 12 limb joints when both have them, else all shared).
    align : ``none``, or ``rigid`` for one rotation + translation fitted over all scored points.
    estimate_path, truth_path : files named in errors.
    """
    require(align in ALIGN_MODES, f"unknown alignment {align!r} (choose {', '.join(ALIGN_MODES)})")
    names, scored = choose_joints(estimate.names, truth.names, joints, path=estimate_path)
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
        rms_axis_m=dict(zip("xyz", map(float, rms))), align=info)


def evaluate_files(estimate_path: str | Path, truth_path: str | Path, *, joints=None,
                   align: str = "none") -> tuple[Evaluation, JointsTable, JointsTable]:
    """Read both joints.csv-convention files and :func:`evaluate` them; returns the tables too."""
    est = read_joints_csv(estimate_path)
    ref = read_joints_csv(truth_path)
    return (evaluate(est, ref, joints=joints, align=align, estimate_path=estimate_path,
                     truth_path=truth_path), est, ref)


def summary_doc(ev: Evaluation) -> dict:
    """The ``eval.json`` document (metres; see docs/evaluation.md)."""
    return {
        "mpjpe_m": round(ev.mpjpe_m, 6),
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
