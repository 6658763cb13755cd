"""Projected 2D capsules: the interface between geometry (float, tolerance) and raster (exact).

A 3D capsule (hull of two spheres) projects to the hull of two discs. Its 2D record is a row of
``CAP_FIELDS`` float32 numbers (pixels)::

    x0 y0 r0  x1 y1 r1  (4 corners of the tangent quad: T0+ T0- T1- T1+)  flag

* the two discs ``(x0, y0, r0)`` and ``(x1, y1, r1)``;
* the quad between the discs' outer tangent points, in the order that makes
  ``cross(B - A, P - A) >= 0`` mean "inside" for every edge ``A -> B`` (image axes: u right, v down);
* ``flag``: 0 = not drawn (a sphere behind the camera), 1 = discs only (one disc contains the other
  or the capsule is a point), 2 = discs + quad.

The pixel set of a capsule is ``disc0 | disc1 | quad`` evaluated at pixel centres after the fixed
point quantisation of :mod:`ipf_jax.raster`; that set is what the JAX kernels and the NumPy
reference must agree on exactly. This module is written against the array namespace ``xp`` so the
same definition serves both sides (it is geometry, compared to a tolerance, never bit-for-bit).
"""
from __future__ import annotations

CAP_FIELDS = 15
FLAG = 14


def capsule_outline(xp, c0, r0, c1, r1, drawn):
    """2D capsule records from projected discs.

    c0, c1 : (..., 2) disc centres (pixels);  r0, r1 : (...,) radii (pixels);
    drawn : (...,) bool (False: behind the camera).  Returns (..., 15).
    """
    d = c1 - c0
    length = xp.sqrt(d[..., 0] ** 2 + d[..., 1] ** 2)
    quad_ok = (length > xp.abs(r0 - r1) + 1e-3) & (length > 1e-3)
    safe_len = xp.where(quad_ok, length, 1.0)
    u = d / safe_len[..., None]
    n = xp.stack([-u[..., 1], u[..., 0]], axis=-1)
    sin_b = xp.where(quad_ok, (r0 - r1) / safe_len, 0.0)
    cos_b = xp.sqrt(xp.clip(1.0 - sin_b * sin_b, 0.0, 1.0))
    m_plus = cos_b[..., None] * n + sin_b[..., None] * u
    m_minus = -cos_b[..., None] * n + sin_b[..., None] * u
    t0p = c0 + r0[..., None] * m_plus
    t0m = c0 + r0[..., None] * m_minus
    t1m = c1 + r1[..., None] * m_minus
    t1p = c1 + r1[..., None] * m_plus
    flag = xp.where(drawn, xp.where(quad_ok, 2.0, 1.0), 0.0)
    return xp.concatenate([c0, r0[..., None], c1, r1[..., None], t0p, t0m, t1m, t1p,
                           flag[..., None]], axis=-1).astype(xp.float32)
