"""Cosine and sine of the joint angles, as elementwise arithmetic the CPU compiler vectorises.

XLA's CPU backend computes ``sin`` and ``cos`` one element at a time (measured on this project's
2-core Xeon, float32, 512-particle batches: 9.7 ns per element for either, against 0.7-1.4 ns for
a square root, a division or an ``exp``): in the batched forward kinematics the 31 joint angles'
sines and cosines were half of the stage's time. :func:`sincos` computes both from one range
reduction and two short polynomials, all of them multiplies, adds and selects.

Accuracy (float32, checked by ``tests/test_trig.py`` against float64 NumPy): absolute error
below 2e-7 for |x| <= 100 rad (measured: at most 9.2e-8, about 1.5 units in the last place of a
value near 1; NumPy's float32 ``cos``: 7.1e-8). The joint angles are within [-2 pi, 2 pi]
(``root_yaw`` is wrapped). Not for large arguments: beyond |x| ~ 1e6 the reduction loses r, and
from ~1e7 the results leave [-1, 1]. NaN and inf give NaN; ``sin(-0.0)`` is +0.0.

The reduction is Cody and Waite's: x = k pi/2 + r with k the nearest integer to x 2/pi, pi/2
split in three float32 parts: k times the first (8 significant bits) is exact for |k| < 2**16,
k times the second rounds by at most 2**-30 for |x| <= 100, the third carries the rest; then
r is in [-pi/4, pi/4]. The polynomials' coefficients are a least-squares fit on 2000 Chebyshev
nodes of [0, pi/4] made for this module (odd polynomial of degree 7 for the sine, even of degree
8 for the cosine; with the float32 coefficients their error in float64 is 3.4e-9 and 4.9e-10).
"""
from __future__ import annotations

import numpy as np

_TWO_OVER_PI = np.float32(2.0 / np.pi)
# pi/2 = _PIO2_1 + _PIO2_2 + _PIO2_3; _PIO2_1 has 8 significant bits, _PIO2_2 its float32 rest
_PIO2_1 = np.float32(1.5703125)
_PIO2_2 = np.float32(np.pi / 2 - 1.5703125)
_PIO2_3 = np.float32(np.pi / 2 - 1.5703125 - float(_PIO2_2))
# sin r = r + r z (s1 + z (s2 + z s3)),  cos r = 1 - z / 2 + z^2 (c1 + z (c2 + z c3)),  z = r^2
_S1, _S2, _S3 = np.float32(-0.16666655), np.float32(0.008332186), np.float32(-0.0001951815)
_C1, _C2, _C3 = np.float32(0.041666646), np.float32(-0.0013887365), np.float32(2.4438232e-05)


def sincos(xp, x):
    """(cos x, sin x) of a float32 array ``x``, elementwise. With NumPy (``xp`` is ``numpy``) its
    own ``cos`` and ``sin``; with any other array library (JAX), the polynomial above."""
    if xp is np:
        return np.cos(x), np.sin(x)
    k = xp.round(x * _TWO_OVER_PI)
    r = ((x - k * _PIO2_1) - k * _PIO2_2) - k * _PIO2_3
    z = r * r
    s = r + r * z * (_S1 + z * (_S2 + z * _S3))
    c = (np.float32(1) - np.float32(0.5) * z) + z * z * (_C1 + z * (_C2 + z * _C3))
    n = k.astype(xp.int32)  # the quadrant: n mod 4 (two's complement: -1 & 3 == 3)
    odd = (n & 1) == 1
    s_, c_ = xp.where(odd, c, s), xp.where(odd, s, c)
    return (xp.where(((n + 1) & 2) != 0, -c_, c_),
            xp.where((n & 2) != 0, -s_, s_))
