"""An optional weak prior that the pelvis is level (``--pelvis-prior SIGMA``; off by default).

The pelvis's roll (its tilt to the side, ``root_roll``) is nearly unobservable in silhouettes: a
pelvis rolled by 15 deg with the trunk bent back by 15 deg (``trunk_lateral``) and the hips
abducted to match casts almost the silhouettes of a level pelvis, so the likelihood is flat along
that combination and the filter drifts on it (docs/fipf.md). With the prior, every weight the
tracker computes (its filter, the initialisation and recovery searches) is multiplied by
``exp(-roll^2 / (2 sigma^2))``; the shape fit's own scores are not.

Measured with sigma 20 deg on the visible 4-camera walks (seeds 0/1/2): the tracked pelvis's tilt
off the truth's by 1.2 deg on the run's mean instead of 4.4 (none over 5 deg instead of 11 of
30 runs). The joint positions were not better (10 walks 27.5 -> 27.8 mm) and sit-to-stand was
worse (60.1 -> 66.3 mm), so it is an option for walking trials whose pelvic obliquity matters,
not the default (docs/fipf.md).
"""
from __future__ import annotations

import numpy as np

from ..body.model import DOF_INDEX

ROLL = DOF_INDEX["root_roll"]


def level_pelvis(particles: np.ndarray, sigma_deg: float) -> np.ndarray:
    """(N,) prior factors in (0, 1] of (N, D) particles: 1 for a level pelvis; all 1 with
    ``sigma_deg`` 0."""
    roll = np.asarray(particles, float)[:, ROLL]
    if sigma_deg <= 0:
        return np.ones(len(roll))
    return np.exp(-0.5 * (roll / np.deg2rad(sigma_deg)) ** 2)
