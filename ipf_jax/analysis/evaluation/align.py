"""Putting an estimate and a reference on the same clock and, optionally, in the same frame.

Time: the reference (e.g. 100 Hz Vicon) is linearly interpolated at the estimate's ``time_s``
(e.g. 20 Hz video). Times within :data:`TIME_SNAP_S` of a reference sample take that sample as it
is, so a 20 Hz estimate of a 100 Hz reference is scored against measured values, not blends of two
samples with a rounding-error weight.

Space: ``rigid`` fits one rotation and translation (no scale; Kabsch/Umeyama) that carries the
estimate onto the reference over every scored frame and joint, for estimates expressed in another
world frame than the reference.
"""
from __future__ import annotations

import numpy as np

from ...errors import IPFError

TIME_SNAP_S = 1e-6  # seconds: a time this close to a reference sample uses that sample


def resample(times: np.ndarray, ref_times: np.ndarray, ref_points: np.ndarray,
             *, path=None) -> tuple[np.ndarray, np.ndarray]:
    """Reference points at other times, by linear interpolation.

    Parameters
    ----------
    times : (T,) seconds at which the reference is wanted.
    ref_times : (R,) strictly increasing reference times, seconds.
    ref_points : (R, J, 3) reference points (nan where a point is missing).
    path : file named in the error when ``ref_times`` is not strictly increasing.

    Returns
    -------
    points : (T, J, 3) interpolated points; nan outside ``ref_times`` or next to a missing sample.
    inside : (T,) bool, True where ``times`` lies within the reference's time range.
    """
    times = np.asarray(times, float)
    ref_times = np.asarray(ref_times, float)
    ref_points = np.asarray(ref_points, float)
    if len(ref_times) > 1 and not np.all(np.diff(ref_times) > 0):
        raise IPFError("time_s must increase strictly from row to row", path)
    inside = (times >= ref_times[0] - TIME_SNAP_S) & (times <= ref_times[-1] + TIME_SNAP_S)
    out = np.full((len(times),) + ref_points.shape[1:], np.nan)
    if len(ref_times) == 1:
        out[inside] = ref_points[0]
        return out, inside
    nearest = np.clip(np.searchsorted(ref_times, times), 1, len(ref_times) - 1)
    nearest = np.where(np.abs(ref_times[nearest - 1] - times) <= np.abs(ref_times[nearest] - times),
                       nearest - 1, nearest)  # (T,) closest sample
    snap = np.abs(ref_times[nearest] - times) <= TIME_SNAP_S
    lo = np.clip(np.searchsorted(ref_times, times, side="right") - 1, 0, len(ref_times) - 2)
    a = ((times - ref_times[lo]) / (ref_times[lo + 1] - ref_times[lo]))[:, None, None]
    blend = (1.0 - a) * ref_points[lo] + a * ref_points[lo + 1]  # (T, J, 3)
    out[inside] = np.where(snap[:, None, None], ref_points[nearest], blend)[inside]
    return out, inside


def rigid_fit(source: np.ndarray, target: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotation R (3, 3) and translation t (3,) minimising sum |R source + t - target|^2.

    source, target : (P, 3) corresponding points (P >= 3, not all on one line). No scale is
    fitted: a wrong body size must stay visible in the error.
    """
    source = np.asarray(source, float)
    target = np.asarray(target, float)
    mu_s, mu_t = source.mean(0), target.mean(0)
    cov = (target - mu_t).T @ (source - mu_s)  # (3, 3)
    u, _, vt = np.linalg.svd(cov)
    flip = np.diag([1.0, 1.0, np.sign(np.linalg.det(u @ vt)) or 1.0])  # a rotation, never a mirror
    rot = u @ flip @ vt
    return rot, mu_t - rot @ mu_s


def apply_rigid(points: np.ndarray, rot: np.ndarray, shift: np.ndarray) -> np.ndarray:
    """(..., 3) points moved by ``rot @ p + shift``."""
    return np.asarray(points, float) @ np.asarray(rot).T + np.asarray(shift)
