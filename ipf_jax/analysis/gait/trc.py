"""Read OpenSim/Vicon ``.trc`` marker files (tab-separated text) into :class:`MarkerData`.

Layout: ``PathFileType`` line, a line of keys (``DataRate ... NumFrames NumMarkers Units ...``)
and one of their values, ``Frame# Time <marker> ...`` (one label per three columns), an
``X1 Y1 Z1 ...`` line, then one row per frame (a blank line before the rows is optional). An
empty cell is a missing coordinate. Everything is checked before it is trusted: the header
counts against the label line and the rows actually present, the rate, the time column (the
clock used; a ``DataRate`` more than 1 % off it is noted), and the file size
(:data:`MAX_TRC_BYTES`), so a damaged file ends in one :class:`IPFError` naming it.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ...errors import IPFError
from .markerdata import MarkerData, from_columns, normalise_units

MAX_TRC_BYTES = 256 << 20


def read_trc(path: str | Path) -> MarkerData:
    """Read a ``.trc`` file; raises :class:`IPFError` naming the file for anything malformed."""
    path = Path(path)
    lines = _lines(path)
    header, rate, n_frames, names = _header(lines, path)
    table = _rows(lines, n_frames, len(names), path)
    time, rate, mismatch = _clock(table[:, 1], rate, path)
    xyz = table[:, 2:].reshape(len(table), len(names), 3).transpose(1, 0, 2)   # (M, T, 3)
    markers, notes = from_columns(names, xyz)
    notes = mismatch + notes
    units = header.get("Units")
    unit = normalise_units(units)
    if units and unit is None:
        notes += (f"TRC Units {units!r} not understood: units inferred from the body",)
    return MarkerData(time, markers, unit, rate, None, notes)


def _lines(path: Path) -> list[str]:
    try:
        size = path.stat().st_size
        if size > MAX_TRC_BYTES:
            raise IPFError(f"TRC file of {size >> 20} MiB is larger than the "
                           f"{MAX_TRC_BYTES >> 20} MiB this reader accepts", path)
        raw = path.read_bytes()
    except OSError as e:
        raise IPFError(f"cannot read TRC ({e})", path) from None
    if b"\x00" in raw:
        raise IPFError("not a TRC file (binary content)", path)
    lines = raw.decode("latin-1").splitlines()
    if len(lines) < 5 or not lines[0].startswith("PathFileType"):
        raise IPFError("not a TRC file (no 'PathFileType' header, or the header is cut short)",
                       path)
    return lines


def _header(lines: list[str], path: Path) -> tuple[dict, float, int, list[str]]:
    """(key -> value, DataRate, NumFrames, marker names) of the header, each checked."""
    # values are padded with runs of tabs and spaces; neither keys nor values contain blanks
    header = dict(zip(lines[1].split(), lines[2].split()))
    try:
        rate = float(header["DataRate"])
        n_frames = int(float(header["NumFrames"]))
        n_markers = int(float(header["NumMarkers"]))
    except (KeyError, ValueError, OverflowError):
        raise IPFError("TRC header lacks a numeric DataRate, NumFrames or NumMarkers", path) \
            from None
    if not (np.isfinite(rate) and rate > 0):
        raise IPFError(f"TRC DataRate {header['DataRate']!r} is not a positive number", path)
    if n_frames < 1 or n_markers < 1:
        raise IPFError(f"TRC header says {n_frames} frames of {n_markers} markers", path)
    names_row = lines[3].split("\t")
    if len(names_row) < 2 or names_row[1].strip().lower() != "time":
        raise IPFError("TRC line 4 must start with 'Frame#<tab>Time'", path)
    names = [n.strip() for n in names_row[2:] if n.strip()]
    if len(names) != n_markers:
        raise IPFError(f"TRC header says {n_markers} markers, line 4 names {len(names)}", path)
    return header, rate, n_frames, names


def _rows(lines: list[str], n_frames: int, n_markers: int, path: Path) -> np.ndarray:
    """(T, 2 + 3 M) the data rows; empty cells are NaN; counts checked against the header."""
    width = 2 + 3 * n_markers
    rows, counts = [], []
    for lineno, line in enumerate(lines[5:], start=6):
        if not line.strip():
            continue
        cells = line.split("\t")
        if len(cells) < 2:
            raise IPFError(f"line {lineno}: truncated TRC row", path)
        if len(cells) > width + 1 and any(c.strip() for c in cells[width:]):
            raise IPFError(f"line {lineno}: {len(cells)} fields, more than the {width} of "
                           f"{n_markers} markers", path)
        counts.append(len(cells))
        cells = (cells + [""] * width)[:width]
        try:
            rows.append([float(c) if c.strip() else np.nan for c in cells])
        except ValueError:
            raise IPFError(f"line {lineno}: non-numeric TRC value", path) from None
        if len(rows) > n_frames:
            break
    if len(rows) != n_frames:
        raise IPFError(f"TRC truncated or inconsistent: header says {n_frames} frames, "
                       f"found {len(rows) if len(rows) <= n_frames else 'more'} data rows", path)
    # Writers keep every tab of an empty marker, so a short last row means the file was cut.
    if len(counts) > 1 and counts[-1] < min(counts[:-1]):
        raise IPFError(f"the last TRC row has {counts[-1]} fields, the others at least "
                       f"{min(counts[:-1])} (file truncated)", path)
    return np.array(rows)


def _clock(time: np.ndarray, rate: float, path: Path) -> tuple[np.ndarray, float, tuple]:
    """The Time column checked; the rate it shows when DataRate disagrees by more than 1 %."""
    if not np.all(np.isfinite(time)):
        raise IPFError("TRC Time column has empty or non-finite cells (truncated row?)", path)
    mismatch = ()
    if len(time) > 1:
        steps = np.diff(time)
        if np.any(steps <= 0):
            raise IPFError("TRC Time column does not increase", path)
        measured = 1.0 / float(np.median(steps))
        if abs(measured - rate) > 0.01 * rate:
            mismatch = ((f"TRC DataRate {rate:g} Hz disagrees with its Time column "
                         f"({measured:.4g} Hz): the Time column is used"),)
            rate = measured
    return time, rate, mismatch
