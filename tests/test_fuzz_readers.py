"""Fuzzed readers: every file reader either returns valid data or raises one IPFError naming the
file; never another exception, never a silent wrong answer.

Readers here: joints.csv (and any CSV in its convention), poses.csv rows, shape files, limits
files, mask images. (Calibration files, dataset.json, TRC and C3D have their own fuzz tests beside
their readers' tests.) Each test starts from a valid file and damages it the ways files get
damaged: cut short, bytes overwritten, numbers replaced by nan / inf / huge values / text, cells
and rows dropped, wrong JSON types. ``HYPOTHESIS_EXPLORE=N`` runs N examples per test instead of
the small fixed set of the default suite.
"""
from __future__ import annotations

import json
import os
import struct
import zlib

import cv2
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from ipf_jax.body.limits import limits_to_json, load_limits
from ipf_jax.body.model import DOF_NAMES, NUM_DOF, POINT_NAMES
from ipf_jax.body.shape import default_shape, load_shape
from ipf_jax.cli import main
from ipf_jax.data.runfiles import (
    JOINT_COLUMNS,
    POSE_COLUMNS,
    read_joints_csv,
    read_pose_rows,
)
from ipf_jax.data.silhouette import read_mask
from ipf_jax.errors import IPFError

_EXPLORE = int(os.environ.get("HYPOTHESIS_EXPLORE", "0"))
FUZZ = settings(max_examples=_EXPLORE or 40, deadline=None, derandomize=not _EXPLORE,
                suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])

BAD_NUMBERS = ["nan", "inf", "-inf", "1e308", "-1e309", "abc", "", "1,2", "0x1F", "1e5000", "--3"]


def _csv(columns, rows) -> str:
    return ",".join(columns) + "\n" + "\n".join(",".join(r) for r in rows) + "\n"


def valid_joints_text(n=4) -> str:
    rng = np.random.default_rng(0)
    rows = [[str(t), f"{t / 20:.6f}"] + [f"{v:.6f}" for v in rng.normal(0, 1, 3 * len(POINT_NAMES))]
            for t in range(n)]
    return _csv(JOINT_COLUMNS, rows)


def valid_poses_text(n=3) -> str:
    rows = [[str(t), f"{t / 20:.6f}"] + ["0.1"] * NUM_DOF for t in range(n)]
    return _csv(POSE_COLUMNS, rows)


@st.composite
def damaged_text(draw, text: str):
    """A valid text damaged in 1-3 ways."""
    for _ in range(draw(st.integers(1, 3))):
        how = draw(st.sampled_from(["cut", "bytes", "cell", "drop_cell", "drop_row", "dup_col"]))
        lines = text.split("\n")
        if how == "cut":
            text = text[: draw(st.integers(0, max(len(text) - 1, 0)))]
        elif how == "bytes":
            pos = draw(st.integers(0, max(len(text) - 1, 0)))
            junk = draw(st.text(alphabet=",\n\t\r\x00éé;.-e0123456789", min_size=1, max_size=6))
            text = text[:pos] + junk + text[pos + len(junk):]
        elif how in ("cell", "drop_cell") and len(lines) > 1:
            r = draw(st.integers(0, len(lines) - 1))
            cells = lines[r].split(",")
            c = draw(st.integers(0, len(cells) - 1))
            if how == "cell":
                cells[c] = draw(st.sampled_from(BAD_NUMBERS))
            else:
                del cells[c]
            lines[r] = ",".join(cells)
            text = "\n".join(lines)
        elif how == "drop_row" and len(lines) > 1:
            del lines[draw(st.integers(0, len(lines) - 1))]
            text = "\n".join(lines)
        elif how == "dup_col":
            lines = [ln + "," + ln.split(",")[-1] if ln else ln for ln in lines]
            text = "\n".join(lines)
    return text


def _write(tmp_path, name, content) -> os.PathLike:
    path = tmp_path / name
    (path.write_bytes if isinstance(content, bytes) else path.write_text)(content)
    return path


def _names_file(e: IPFError, path) -> None:
    assert e.path is not None and os.path.samefile(e.path, path), f"error does not name the file: {e}"
    assert "\n" not in str(e), f"error is not one line: {e!r}"


@FUZZ
@given(damaged_text(valid_joints_text()))
def test_joints_csv_reader_returns_valid_tables_or_one_error(tmp_path_factory, text):
    path = _write(tmp_path_factory.mktemp("j"), "joints.csv", text)
    try:
        table = read_joints_csv(path)
    except IPFError as e:
        _names_file(e, path)
        return
    assert table.points.ndim == 3 and table.points.shape[2] == 3
    assert len(table.frame) == len(table.time_s) == len(table.points) > 0
    assert np.all(np.isfinite(table.time_s))
    finite = table.points[~np.isnan(table.points)]
    assert np.all(np.abs(finite) <= 1e5)  # nan = missing; never inf or astronomic


@FUZZ
@given(damaged_text(valid_poses_text()))
def test_pose_rows_reader_returns_finite_poses_or_one_error(tmp_path_factory, text):
    path = _write(tmp_path_factory.mktemp("p"), "poses.csv", text)
    try:
        q = read_pose_rows(path)
    except IPFError as e:
        _names_file(e, path)
        return
    assert q.ndim == 2 and q.shape[1] == NUM_DOF and len(q) > 0
    assert np.all(np.isfinite(q)) and np.all(np.abs(q) <= 1e4)


JSON_JUNK = st.one_of(st.none(), st.booleans(), st.integers(-10**20, 10**20), st.text(max_size=5),
                      st.floats(allow_nan=True, allow_infinity=True), st.lists(st.integers(), max_size=3),
                      st.just({}), st.just("nan"))


@st.composite
def damaged_json(draw, doc: dict, section: str):
    """A valid shape/limits document with 1-3 values replaced, removed or added."""
    doc = json.loads(json.dumps(doc))
    for _ in range(draw(st.integers(1, 3))):
        how = draw(st.sampled_from(["value", "remove", "add", "top", "text"]))
        keys = sorted(doc[section]) if isinstance(doc.get(section), dict) else []
        if how == "value" and keys:
            doc[section][draw(st.sampled_from(keys))] = draw(JSON_JUNK)
        elif how == "remove" and keys:
            del doc[section][draw(st.sampled_from(keys))]
        elif how == "add" and isinstance(doc.get(section), dict):
            doc[section][draw(st.text(min_size=1, max_size=8))] = draw(JSON_JUNK)
        elif how == "top":
            doc[draw(st.sampled_from([section, "height_m", "name"]))] = draw(JSON_JUNK)
        else:
            text = json.dumps(doc)
            return text[: draw(st.integers(0, len(text) - 1))]
    try:
        return json.dumps(doc, allow_nan=True)
    except ValueError:
        return "{"


@FUZZ
@given(damaged_json(default_shape().to_json(), "params"))
def test_shape_reader_returns_a_usable_shape_or_one_error(tmp_path_factory, text):
    path = _write(tmp_path_factory.mktemp("s"), "shape.json", text)
    try:
        shape = load_shape(path)
    except IPFError as e:
        _names_file(e, path)
        return
    assert np.all(np.isfinite(shape.values)) and 0.5 <= shape.height_m <= 2.6


@FUZZ
@given(damaged_json(limits_to_json(load_limits("default")), "dofs"))
def test_limits_reader_returns_ordered_finite_ranges_or_one_error(tmp_path_factory, text):
    path = _write(tmp_path_factory.mktemp("l"), "limits.json", text)
    try:
        lim = load_limits(path)
    except IPFError as e:
        _names_file(e, path)
        return
    assert np.all(np.isfinite(lim.lower)) and np.all(lim.lower <= lim.upper)
    assert lim.lower.shape == (len(DOF_NAMES),)


def _mask_files():
    m = np.zeros((24, 32), np.uint8)
    m[5:20, 10:22] = 255
    out = {}
    for ext in (".png", ".bmp", ".jpg", ".tif"):
        ok, buf = cv2.imencode(ext, m)
        out[ext] = buf.tobytes()
    ok, buf = cv2.imencode(".png", (m.astype(np.uint16) * 257))  # 16-bit
    out["16bit.png"] = buf.tobytes()
    ok, buf = cv2.imencode(".tif", np.where(m > 0, np.float32(1.0), np.float32(np.nan)))
    out["nan.tif"] = buf.tobytes()
    ok, buf = cv2.imencode(".tif", np.where(m > 0, np.float32(np.inf), np.float32(0)))
    out["inf.tif"] = buf.tobytes()
    return out


MASKS = _mask_files()


def _png_claiming(width: int, height: int) -> bytes:
    """A PNG whose header claims a huge size (one tiny IDAT chunk): must not be decoded."""
    def chunk(kind, body):
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(b"\x00" * 64)) + chunk(b"IEND", b""))


@FUZZ
@given(st.sampled_from(sorted(MASKS)), st.data())
def test_mask_reader_returns_a_boolean_mask_or_one_error(tmp_path_factory, kind, data):
    raw = bytearray(MASKS[kind])
    how = data.draw(st.sampled_from(["cut", "bytes", "none", "empty"]))
    if how == "cut":
        raw = raw[: data.draw(st.integers(0, len(raw) - 1))]
    elif how == "bytes":
        for _ in range(data.draw(st.integers(1, 8))):
            raw[data.draw(st.integers(0, len(raw) - 1))] = data.draw(st.integers(0, 255))
    elif how == "empty":
        raw = bytearray()
    ext = os.path.splitext(kind)[1]
    path = _write(tmp_path_factory.mktemp("m"), f"image0000{ext}", bytes(raw))
    try:
        mask = read_mask(path)
    except IPFError as e:
        _names_file(e, path)
        return
    assert mask.dtype == bool and mask.ndim == 2 and mask.size > 0


@pytest.mark.parametrize("size", [(100_000, 100_000), (40_000, 10), (0, 10)])
def test_a_mask_header_claiming_a_huge_or_empty_image_is_refused_before_decoding(tmp_path, size):
    path = _write(tmp_path, "image0000.png", _png_claiming(*size))
    with pytest.raises(IPFError, match="header declares"):
        read_mask(path)


@pytest.mark.parametrize("content", ["", "frame,time_s\n", "frame,time_s,a_x,a_y,a_z\n0,0,1,2,inf\n",
                                     "\x00\x01\x02", "frame,time_s,a_x,a_y,a_z\n0.5,0,1,2,3\n"])
def test_eval_on_a_damaged_csv_is_one_line_exit_2_and_writes_nothing(tmp_path, capsys, content):
    bad = _write(tmp_path, "joints.csv", content)
    good = _write(tmp_path, "truth.csv", valid_joints_text())
    out = tmp_path / "ev"
    assert main(["eval", str(bad), str(good), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: ") and str(bad) in err[0]
    assert not out.exists() or not any(out.iterdir())  # no half-written file
