"""Run-directory files: ``joints.csv``, ``poses.csv`` (appended and flushed frame by frame, fsynced with each checkpoint), ``run.json``.

Rows are written with 6 decimals and ``nan`` for missing frames, so a run that is killed keeps
every frame it finished, and a resumed run produces byte-identical files (see :mod:`.checkpoint`).
"""
from __future__ import annotations

import json
import math
import os
import tempfile
from pathlib import Path
from typing import NamedTuple

import numpy as np

from ..body.model import DOF_NAMES, POINT_NAMES
from ..errors import IPFError, require

JOINT_COLUMNS = ["frame", "time_s"] + [f"{p}_{a}" for p in POINT_NAMES for a in "xyz"]
POSE_COLUMNS = ["frame", "time_s"] + list(DOF_NAMES)


def _fmt(values, decimals: int = 6) -> str:
    """Values with ``decimals``, ``nan`` when not finite: Python floats, formatted as NumPy's
    float64 scalars format (a frame's 88 values in ~20 us instead of ~110)."""
    spec = f".{decimals}f"
    return ",".join(format(v, spec) if math.isfinite(v) else "nan"
                    for v in np.asarray(values, np.float64).ravel().tolist())


def format_row(frame: int, time_s: float, values, decimals: int = 6) -> str:
    """One run-CSV line: frame, time (6 decimals), values (``decimals``, ``nan`` when not finite)."""
    return f"{frame},{time_s:.6f},{_fmt(values, decimals)}\n"


def write_rows(path: str | Path, columns: list[str], frames, time_s, values,
               decimals: int = 6) -> None:
    """A whole run CSV at once (what :class:`CsvAppender` writes row by row), atomically.

    values : (T, len(columns) - 2); ``decimals`` of the values (6: micrometres in metres).
    """
    path = Path(path)
    text = ",".join(columns) + "\n" + "".join(
        format_row(int(f), float(t), v, decimals) for f, t, v in zip(frames, time_s, np.asarray(values)))
    tmp = path.with_name(path.name + ".tmp")
    try:
        tmp.write_text(text)
        os.replace(tmp, path)
    except OSError as e:
        tmp.unlink(missing_ok=True)  # no stray FILE.tmp beside a file that could not be written
        raise IPFError(f"cannot write ({e.strerror or e})", path) from None


class CsvAppender:
    """Append rows to a CSV, flushing each one (a killed process leaves every row written).

    :meth:`sync` puts the rows on disk (fsync): the tracker calls it before each checkpoint, whose
    row count is what a resume keeps, so a checkpoint never counts rows a power cut could lose;
    an fsync per row cost more than a frame's selection and prediction together.

    keep_rows : resume: keep the header and this many rows of the existing file, append after.
    lazy : create a new file only with its first row, so a run that fails before writing anything
        leaves a previous run's file as it was.
    """

    def __init__(self, path: Path, columns: list[str], keep_rows: int | None = None, *,
                 lazy: bool = False):
        self.path = Path(path)
        self._header = ",".join(columns) + "\n"
        self._fh = None
        self._unsynced = False  # rows written since the last fsync
        if keep_rows is None or not self.path.exists():
            require(not keep_rows, f"cannot resume: the file is missing (the checkpoint has {keep_rows} "
                    "rows of it)", self.path)
            if not lazy:
                self._start()
        else:
            lines = self.path.read_text().splitlines(keepends=True)
            require(lines and lines[0].strip() == ",".join(columns),
                    "cannot resume: unexpected header", self.path)
            whole = len(lines) - 1 - (not lines[-1].endswith("\n"))  # a row cut short is no row
            require(whole >= keep_rows,
                    f"cannot resume: the file has {whole} whole rows, the checkpoint needs {keep_rows} "
                    "(it was cut or edited after the run stopped; rerun without --resume)", self.path)
            self.path.write_text("".join(lines[: keep_rows + 1]))
            self._fh = open(self.path, "a")
            self._unsynced = True  # the cut file reaches the disk with the next sync

    def _start(self) -> None:
        self._fh = open(self.path, "w")
        self._fh.write(self._header)
        self._fh.flush()
        self._unsynced = True

    def write(self, frame: int, time_s: float, values: np.ndarray) -> None:
        if self._fh is None:
            self._start()
        self._fh.write(format_row(frame, time_s, values))
        self._fh.flush()
        self._unsynced = True

    def sync(self) -> None:
        """Every row written so far on disk (no fsync when nothing was written since the last:
        closing after the last checkpoint's sync costs nothing)."""
        if self._fh is not None and self._unsynced:
            self._fh.flush()
            os.fsync(self._fh.fileno())
            self._unsynced = False

    def close(self) -> None:
        if self._fh is not None:
            self.sync()
            self._fh.close()


def atomic_temp(path: Path) -> tuple[int, str]:
    """(fd, name) of a temporary file beside ``path``, to be renamed onto it, readable like any
    file the user creates (``mkstemp`` makes them 0600: results others could not read)."""
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=path.name, suffix=".tmp")
    if hasattr(os, "fchmod"):  # POSIX
        umask = os.umask(0)
        os.umask(umask)
        os.fchmod(fd, 0o666 & ~umask)
    return fd, tmp


def write_json_atomic(path: Path, doc) -> None:
    """Write JSON via a temporary file and rename (never a half-written file). Values of ``doc``
    may be :class:`EncodedList` (see :func:`dumps`)."""
    path = Path(path)
    fd, tmp = atomic_temp(path)
    with os.fdopen(fd, "w") as fh:
        fh.write(dumps(doc, indent=1))
        fh.flush()
        os.fsync(fh.fileno())
    os.replace(tmp, path)


class EncodedList:
    """A list of JSON values that only grows, each value encoded once.

    A run's per-frame records go into every ``run.json`` and checkpoint; encoding them all again
    each time costs a time that grows with the run (1000 records: ~65 ms per checkpoint, json's
    indented encoder being pure Python), so :func:`dumps` splices their texts instead.
    """

    def __init__(self):
        self._values: list = []
        self._texts: dict[int | None, list[str]] = {}  # indent -> one text per value

    def update(self, values) -> "EncodedList":
        """Hold ``values`` (a sequence that starts with the values held, as a growing tuple does;
        anything else is encoded anew)."""
        n = len(self._values)
        if len(values) < n or (n and values[n - 1] is not self._values[n - 1]):
            self._values, self._texts, n = [], {}, 0
        self._values.extend(values[n:])
        return self

    def text(self, indent: int | None, level: int) -> str:
        """The list as ``json.dumps`` writes it as a value ``level`` deep (1: a top-level key's)."""
        texts = self._texts.setdefault(indent, [])
        for v in self._values[len(texts):]:
            texts.append(json.dumps(v, indent=indent, default=_json_default))  # as dumps does
        if not texts:
            return "[]"
        if indent is None:
            return "[" + ", ".join(texts) + "]"
        pad = "\n" + " " * (indent * (level + 1))  # each item's own lines move in with it
        return "[" + pad + ("," + pad).join(t.replace("\n", pad) for t in texts) + "\n" + " " * (indent * level) + "]"


def dumps(doc, indent: int | None = None, *, numpy: bool = True) -> str:
    """``json.dumps(doc, indent=indent)`` (numpy values as lists and numbers; ``numpy=False``:
    a TypeError, as plain ``json.dumps``), the same text, with the top-level values that are
    :class:`EncodedList` spliced in from their texts rather than encoded."""
    spliced = {k: v for k, v in doc.items() if isinstance(v, EncodedList)} if isinstance(doc, dict) else {}
    marks = {k: f"\x00{k}\x00" for k in spliced}
    text = json.dumps({k: marks.get(k, v) for k, v in doc.items()} if spliced else doc,
                      indent=indent, default=_json_default if numpy else None)
    for k, v in spliced.items():
        text = text.replace(json.dumps(marks[k]), v.text(indent, 1), 1)
    return text


def _json_default(o):
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    raise TypeError(f"not JSON serialisable: {type(o)}")


def check_writable(out_dir: Path) -> Path:
    """Create ``out_dir`` and make sure we can write in it (one clear error otherwise)."""
    out_dir = Path(out_dir)
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
        probe = out_dir / ".write_test"
        probe.write_text("")
        probe.unlink()
    except OSError as e:
        raise IPFError(f"output folder is not writable ({e.strerror or e})", out_dir) from None
    return out_dir


def check_output_file(path: Path) -> Path:
    """Make sure ``path`` can be written as a file (its folder created) before the work that fills
    it is done: one clear error for a folder, an unwritable place or an empty name."""
    path = Path(path)
    require(str(path) not in ("", "."), "the output file name is empty")
    require(not path.is_dir(), "the output is a folder: give a file name", path)
    check_writable(path.parent)  # "." for a bare file name
    return path


MAX_TABLE_BYTES = 1 << 30  # a run CSV of a day at 100 Hz is far smaller
MAX_COORD_M = 1e5  # metres: larger coordinates are not positions in a capture volume


class JointsTable(NamedTuple):
    """A ``joints.csv``-convention table: frame (T,), time_s (T,), points (T, J, 3), names (J,)."""

    frame: np.ndarray
    time_s: np.ndarray
    points: np.ndarray
    names: tuple[str, ...]


def read_table(path: str | Path, what: str = "CSV") -> tuple[list[str], np.ndarray]:
    """(header, (T, K) float64 values) of a comma-separated numeric table with one header line.

    Every cell must be a number (``nan`` and ``inf`` parse, an empty cell is ``nan``: a missing
    value; callers decide what they accept); a row with another number of cells than the header, a
    non-numeric cell, a file without rows or one larger than :data:`MAX_TABLE_BYTES` is an
    :class:`IPFError` naming the file and the line.
    """
    path = Path(path)
    try:
        if path.stat().st_size > MAX_TABLE_BYTES:
            raise IPFError(f"larger than {MAX_TABLE_BYTES >> 20} MiB: not a run CSV", path)
        text = path.read_text()
    except FileNotFoundError:
        raise IPFError("file not found", path) from None
    except (OSError, UnicodeDecodeError) as e:
        raise IPFError(f"not a readable {what} ({e})", path) from None
    lines = [(n, ln) for n, ln in enumerate(text.splitlines(), start=1) if ln.strip()]
    require(bool(lines), f"empty {what}", path)
    header = [h.strip() for h in lines[0][1].split(",")]
    twice = sorted({h for h in header if h and header.count(h) > 1})
    require(not twice, f"column(s) {', '.join(twice)} appear more than once in the header", path)
    rows = []
    for n, line in lines[1:]:
        cells = line.split(",")
        require(len(cells) == len(header), f"line {n} has {len(cells)} values, the header "
                f"{len(header)}", path)
        try:
            rows.append([float(c) if c.strip() else np.nan for c in cells])
        except ValueError:
            bad = next(c for c in cells if not _is_number(c))
            raise IPFError(f"line {n}: {bad.strip()[:20]!r} is not a number", path) from None
    require(bool(rows), f"no data rows in the {what}", path)
    return header, np.array(rows, np.float64)


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def read_joints_csv(path: str | Path) -> JointsTable:
    """Read any CSV in the ``joints.csv`` convention (``frame,time_s,<point>_x/_y/_z``, extras ignored)."""
    path = Path(path)
    header, data = read_table(path, "joints CSV")
    require("frame" in header and "time_s" in header, "needs 'frame' and 'time_s' columns", path)
    names = []
    for col in header:
        if col.endswith("_x"):
            name = col[:-2]
            if f"{name}_y" in header and f"{name}_z" in header:
                names.append(name)
    require(names, "no <point>_x,_y,_z column triples", path)
    idx = {c: i for i, c in enumerate(header)}
    frame, time_s = data[:, idx["frame"]], data[:, idx["time_s"]]
    require(bool(np.all(np.isfinite(frame)) and np.all(frame == np.round(frame))
                 and np.all(np.abs(frame) < 2**31)), "'frame' must hold whole frame numbers", path)
    require(bool(np.all(np.isfinite(time_s))), "'time_s' must hold finite times in seconds", path)
    pts = np.stack([data[:, [idx[f"{n}_x"], idx[f"{n}_y"], idx[f"{n}_z"]]] for n in names], axis=1)
    # nan is a missing value (a frame the tracker missed); inf or astronomic values are not metres
    bad = ~np.isnan(pts) & ~(np.abs(pts) <= MAX_COORD_M)
    require(not bad.any(), f"{int(bad.sum())} coordinates are infinite or beyond {MAX_COORD_M:g} m "
            "(coordinates are metres; missing values are nan)", path)
    _check_metres(pts, names, path)
    return JointsTable(frame.astype(np.int64), time_s, pts, tuple(names))


#: A thigh (hip to knee) longer than this is not an adult's in metres: the file is in other units.
MAX_THIGH_M = 1.5


def _check_metres(pts: np.ndarray, names: list[str], path: Path) -> None:
    """One error when the hip-to-knee distances say the coordinates are not metres (mm, cm)."""
    lengths = [np.linalg.norm(pts[:, names.index(f"{s}_hip")] - pts[:, names.index(f"{s}_knee")], axis=-1)
               for s in ("left", "right") if f"{s}_hip" in names and f"{s}_knee" in names]
    lengths = np.concatenate(lengths) if lengths else np.empty(0)
    lengths = lengths[np.isfinite(lengths)]
    if lengths.size:
        thigh = float(np.median(lengths))
        require(thigh <= MAX_THIGH_M, f"the thighs (hip to knee) measure {thigh:g} on the median: "
                "coordinates must be metres (millimetres or centimetres? divide by 1000 or 100)", path)


def read_pose_rows(path: str | Path) -> np.ndarray:
    """(N, D) poses from a CSV with one named column per DOF (poses.csv convention)."""
    path = Path(path)
    header, data = read_table(path, "poses file")
    missing = [d for d in DOF_NAMES if d not in header]
    require(not missing, f"missing DOF columns: {', '.join(missing[:5])}{'...' if len(missing) > 5 else ''}", path)
    q = data[:, [header.index(d) for d in DOF_NAMES]]
    require(bool(np.all(np.isfinite(q))), "poses contain NaN or non-numeric values", path)
    require(bool(np.all(np.abs(q) <= 1e4)), "poses hold values beyond 1e4 (metres or radians)", path)
    return q
