"""Reference likelihood: FK -> projection -> full-image raster -> counts, one particle at a time."""
from __future__ import annotations

import numpy as np

from ..geometry.camera import Camera
from ..geometry.capsule2d import capsule_outline
from ..likelihood.scorer import weights_from_counts
from .camera import project_spheres
from .kinematics import forward_kinematics
from .raster import counts_from_caps

__all__ = ["project_capsules", "counts", "weights_from_counts"]


def project_capsules(q, shape_values, up, cameras: list[Camera]) -> np.ndarray:
    """One particle -> (C, S, 15) float32 capsule records."""
    pose = forward_kinematics(q, shape_values, up)
    out = []
    for cam in cameras:
        uv0, r0, in0 = project_spheres(cam, pose.seg_a, pose.seg_r[:, 0])
        uv1, r1, in1 = project_spheres(cam, pose.seg_b, pose.seg_r[:, 1])
        out.append(capsule_outline(np, uv0, r0, uv1, r1, in0 & in1))
    return np.stack(out)


def counts(particles, shape_values, up, cameras: list[Camera], masks: list[np.ndarray]) -> np.ndarray:
    """(N, D) particles -> (N, C, 3) int64 counts (Nc, Ns, Nm)."""
    particles = np.atleast_2d(np.asarray(particles, float))
    out = np.zeros((len(particles), len(cameras), 3), np.int64)
    for n, q in enumerate(particles):
        caps = project_capsules(q, shape_values, up, cameras)
        for c, mask in enumerate(masks):
            out[n, c] = counts_from_caps(caps[c], np.asarray(mask, bool))
    return out
