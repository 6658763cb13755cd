"""Projected 2D capsules: the interface between geometry (float, tolerance) and raster (exact).

A 3D capsule (hull of two spheres) projects to the hull of two discs. Its 2D record is a row of
``CAP_FIELDS`` float32 numbers (pixels)::

    x0 y0 r0  x1 y1 r1  (4 corners of the tangent quad: T0+ T0- T1- T1+)  flag

* the two discs ``(x0, y0, r0)`` and ``(x1, y1, r1)``;
* the quad between the discs' outer tangent points, in the order that makes
  ``cross(B - A, P - A) >= 0`` mean "inside" for every edge ``A -> B`` (image axes: u right, v down);
* ``flag``: 0 = not drawn (a sphere behind the camera), 1 = discs only (one disc contains the other
  or the capsule is a point), 2 = discs + quad.

The pixel set of a capsule is, row by row, the pixel centres from the leftmost to the rightmost
of its discs' chords and its quad's two tangent sides' crossings, after the fixed point
quantisation of :mod:`ipf_jax.likelihood.raster` (:func:`~ipf_jax.likelihood.raster.solve_rows`):
for the exact hull of two discs, the pixel centres inside it. That set is what the JAX kernels and
the NumPy reference must agree on exactly. This module is written against the array namespace ``xp`` so the
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
    # x and y as separate arrays until the end: XLA's CPU loops are slow on trailing axes of 2
    fields = outline_fields(xp, c0[..., 0], c0[..., 1], r0, c1[..., 0], c1[..., 1], r1, drawn)
    return xp.stack(fields, axis=-1)


def outline_fields(xp, x0, y0, r0, x1, y1, r1, drawn) -> list:
    """The 15 fields of :func:`capsule_outline`, each a float32 array of the inputs' broadcast
    shape (the scorer stacks them on a leading axis, keeping the particles on the last)."""
    dx, dy = x1 - x0, y1 - y0
    length = xp.sqrt(dx * dx + dy * dy)
    quad_ok = (length > xp.abs(r0 - r1) + 1e-3) & (length > 1e-3)
    safe_len = xp.where(quad_ok, length, 1.0)
    ux, uy = dx / safe_len, dy / safe_len  # unit axis; the normal is (-uy, ux)
    sin_b = xp.where(quad_ok, (r0 - r1) / safe_len, 0.0)
    cos_b = xp.sqrt(xp.clip(1.0 - sin_b * sin_b, 0.0, 1.0))
    # outer tangent directions m+ = cos_b n + sin_b u and m- = -cos_b n + sin_b u
    px, py = -cos_b * uy + sin_b * ux, cos_b * ux + sin_b * uy
    mx, my = cos_b * uy + sin_b * ux, -cos_b * ux + sin_b * uy
    flag = xp.where(drawn, xp.where(quad_ok, 2.0, 1.0), 0.0)
    fields = [x0, y0, r0, x1, y1, r1,
              x0 + r0 * px, y0 + r0 * py,  # T0+
              x0 + r0 * mx, y0 + r0 * my,  # T0-
              x1 + r1 * mx, y1 + r1 * my,  # T1-
              x1 + r1 * px, y1 + r1 * py,  # T1+
              flag]
    return [xp.broadcast_to(f, flag.shape).astype(xp.float32) for f in fields]
