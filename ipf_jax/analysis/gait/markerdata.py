"""Raw marker trajectories as a marker file holds them, before any marker set or unit is applied.

:class:`MarkerData` is what the TRC and C3D readers (:mod:`.trc`, :mod:`.c3d`) return and what
:mod:`.markers` turns into body points. :func:`clean` applies the rules every reader shares: a
marker at exactly (0, 0, 0) is a placeholder for "not seen" (several systems store gaps as
zeros), and non-finite values are missing; both become NaN, and the count is noted.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np


class MarkerData(NamedTuple):
    """Raw markers of one file (T frames, M markers).

    time : (T,) seconds.  markers : dict label -> (T, 3) in the file's units (NaN = missing).
    units : ``m``/``cm``/``mm`` as the file says (None when it does not).  rate : Hz.
    up_axis : the up axis the file names (C3D ``POINT:Y_SCREEN``), else None; a hint only.
    notes : remarks made while reading (placeholders replaced).
    """

    time: np.ndarray
    markers: dict
    units: str | None
    rate: float
    up_axis: str | None
    notes: tuple = ()


def from_columns(labels: list, xyz: np.ndarray) -> tuple[dict, tuple]:
    """label -> (T, 3) from M labels and (M, T, 3) values, cleaned (:func:`clean`).

    A label that repeats (Motion Analysis files repeat some) keeps the copy with the most frames
    of data, and a note says so.
    """
    cleaned, notes = clean({i: xyz[i] for i in range(len(labels))})
    out, repeated = {}, []
    for i, label in enumerate(labels):
        if label in out:
            repeated.append(label)
            if _frames(cleaned[i]) <= _frames(out[label]):
                continue
        out[label] = cleaned[i]
    if repeated:
        notes += ((f"repeated marker labels {', '.join(sorted(set(repeated)))}: the copy with "
                   "the most frames of data is used"),)
    return out, notes


def _frames(xyz: np.ndarray) -> int:
    return int(np.all(np.isfinite(xyz), axis=1).sum())


def clean(markers: dict) -> tuple[dict, tuple]:
    """Zeros and non-finite samples -> NaN in every (T, 3) marker; returns (markers, notes)."""
    out, zeros, bad = {}, 0, 0
    for label, xyz in markers.items():
        xyz = np.array(xyz, dtype=float)
        with np.errstate(invalid="ignore"):
            nonfinite = ~np.all(np.isfinite(xyz), axis=1)
            zero = np.all(xyz == 0.0, axis=1)
        bad += int((nonfinite & ~np.all(np.isnan(xyz), axis=1)).sum())
        zeros += int(zero.sum())
        xyz[nonfinite | zero] = np.nan
        out[label] = xyz
    notes = []
    if zeros:
        notes.append(f"{zeros} marker samples at exactly (0, 0, 0) read as missing (the "
                     "placeholder some systems store for an unseen marker)")
    if bad:
        notes.append(f"{bad} marker samples with infinite values read as missing")
    return out, tuple(notes)


def normalise_units(text: str | None) -> str | None:
    """``'mm'``, ``' MM '``, ``'millimeters'`` -> ``'mm'``; unknown or empty -> None."""
    if not text:
        return None
    t = str(text).strip().lower()
    return {"mm": "mm", "millimeter": "mm", "millimeters": "mm", "millimetre": "mm",
            "millimetres": "mm", "cm": "cm", "m": "m", "meter": "m", "meters": "m",
            "metre": "m", "metres": "m"}.get(t)
