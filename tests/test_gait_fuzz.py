"""Fuzzed TRC and C3D readers (issue 12 item 3, gait readers): truncated, corrupt, huge, NaN and
zero-filled files each end in one clear error naming the file, never a traceback, never an abort
of the process, never gigabytes allocated.

Each example reads and analyses the file as ``ipf-jax gait`` does (:func:`ipf_jax.analysis.gait.load`,
:func:`~ipf_jax.analysis.gait.analyse`, the ``gait.json`` document): it succeeds with a document that is
valid JSON (no NaN), or raises :class:`IPFError` with one line naming the file, which the command
prints as ``error: <file>: ...`` with exit status 2 (checked through the command itself on the
seeds and the regressions, where it must also leave no output folder). The seeds are an ipf-jax
TRC and C3D export of a procedural walk (made here) and, when the shared data is present, two real
C3D files in DEC and Intel formats. C3D mutations aim at the structure ezc3d trusts: header words
and floats, parameter records (name length, group id, link, type, dimensions, values), the data
section (truncated, zero-filled, NaN-filled). The wider campaigns (files read in child
processes, and ``-m slow`` here) and the process aborts they found in ezc3d, now refused by
:mod:`ipf_jax.analysis.gait.c3d_check`, are described in ``docs/gait.md``.
"""
from __future__ import annotations

import argparse
import contextlib
import io
import json
import resource
import struct
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from ipf_jax.analysis.export import export_c3d, export_trc, read_run, write_run_dir
from ipf_jax.analysis.gait import analyse, load
from ipf_jax.analysis.gait.report import to_json
from ipf_jax.body.shape import default_shape
from ipf_jax.cli import gait as gait_cli
from ipf_jax.errors import IPFError
from ipf_jax.paths import shared_data_dir
from ipf_jax.viz.synthetic import procedural_walk

MAX_GROWTH_KB = 1 << 20  # 1 GiB of resident memory over the whole module
SETTINGS = settings(max_examples=60, deadline=None, derandomize=True,
                    suppress_health_check=[HealthCheck.function_scoped_fixture,
                                           HealthCheck.too_slow])


@pytest.fixture(scope="module")
def seeds(tmp_path_factory):
    root = tmp_path_factory.mktemp("seeds")
    q = procedural_walk(60, 20.0, shape=default_shape())
    run = read_run(write_run_dir(root / "run", q, shape=default_shape(), fps=20.0))
    out = {"trc": [export_trc(run, root / "walk.trc").read_bytes()],
           "c3d": [export_c3d(run, root / "walk.c3d").read_bytes()]}
    for name in ("motionanalysis_btk_gait/Gait.c3d", "qualisys_ezc3d/Qualisys.c3d"):
        path = shared_data_dir() / "gait_trials" / name
        if path.is_file():
            out["c3d"].append(path.read_bytes())
    return out


@pytest.fixture(scope="module", autouse=True)
def memory_guard():
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    yield
    grown = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before
    assert grown < MAX_GROWTH_KB, f"resident memory grew by {grown / 2**20:.1f} GiB"


def run_gait(path: Path, out: Path) -> tuple[int, str]:
    parser = argparse.ArgumentParser(prog="ipf-jax")
    gait_cli.add_parser(parser.add_subparsers(dest="command", required=True))
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        rc = gait_cli.run(parser.parse_args(["gait", str(path), "--out", str(out)]))
    return rc, err.getvalue()


def check_outcome(path: Path) -> str:
    """Read + analyse + gait.json document: 'ok', or 'error' for a one-line IPFError naming it."""
    try:
        doc = to_json(analyse(load(path)))
    except IPFError as e:
        msg = str(e)
        assert path.name in msg and "\n" not in msg, msg
        return "error"
    json.dumps(doc, allow_nan=False)
    return "ok"


def check_command(path: Path, out: Path) -> int:
    rc, err = run_gait(path, out)
    if rc == 0:
        assert (out / "gait.json").is_file()
        return rc
    lines = err.strip().splitlines()
    assert rc == 2, (rc, err)
    assert len(lines) == 1 and lines[0].startswith("error: ") and path.name in lines[0], err
    assert "Traceback" not in err
    assert not out.exists(), "an error must leave no output folder behind"
    return rc


# --------------------------------------------------------------------------------------------------
# TRC

CELLS = ["nan", "inf", "-inf", "1e308", "-1e308", "", "abc", "0", "1e-320", "9" * 40, "\x00"]
HEADER = ["0", "-5", "nan", "inf", "1e12", "999999999999", "1e308", "0.0001", "x", ""]


@st.composite
def trc_mutation(draw):
    kind = draw(st.sampled_from(["truncate", "bytes", "cell", "header", "zeros", "drop_line",
                                 "dup_line", "empty", "nan_block"]))
    return kind, draw(st.integers(0, 2**31)), draw(st.sampled_from(CELLS)), \
        draw(st.sampled_from(HEADER))


def mutate_trc(data: bytes, mutation) -> bytes:
    kind, n, cell, head = mutation
    rng = np.random.default_rng(n)
    lines = data.split(b"\n")
    if kind == "truncate":
        return data[: n % len(data)]
    if kind == "bytes":
        b = bytearray(data)
        for i in rng.integers(0, len(b), size=1 + n % 20):
            b[i] = int(rng.integers(0, 256))
        return bytes(b)
    if kind == "cell":
        j = 5 + n % (len(lines) - 6)
        cells = lines[j].split(b"\t")
        cells[n % len(cells)] = cell.encode("latin-1")
        lines[j] = b"\t".join(cells)
    elif kind == "header":
        cells = lines[2].split(b"\t")
        cells[n % 8] = head.encode()
        lines[2] = b"\t".join(cells)
    elif kind in ("zeros", "nan_block"):
        a = 6 + n % (len(lines) - 7)
        for j in range(a, min(len(lines), a + 1 + n % 60)):
            cells = lines[j].split(b"\t")
            fill = b"0" if kind == "zeros" else b"nan"
            lines[j] = b"\t".join(cells[:2] + [fill if c.strip() else c for c in cells[2:]])
    elif kind == "drop_line":
        del lines[n % len(lines)]
    elif kind == "dup_line":
        lines.insert(n % len(lines), lines[(n // 7) % len(lines)])
    elif kind == "empty":
        return b""
    return b"\n".join(lines)


@SETTINGS
@given(mutation=trc_mutation())
def test_fuzzed_trc_ends_cleanly(seeds, tmp_path_factory, mutation):
    tmp = tmp_path_factory.mktemp("trc")
    path = tmp / "fuzz.trc"
    path.write_bytes(mutate_trc(seeds["trc"][0], mutation))
    check_outcome(path)


# --------------------------------------------------------------------------------------------------
# C3D


def records(b: bytes) -> list:
    """(position, name length, group id, name end) of each parameter record, walked leniently."""
    pb = b[0]
    ps = (pb - 1) * 512
    end = min(len(b), ps + b[ps + 2] * 512)
    endian = ">" if b[ps + 3] == 86 else "<"
    pos, out = ps + 4, []
    while pos + 2 < end and len(out) < 2000:
        nl = abs(struct.unpack("b", b[pos:pos + 1])[0])
        if nl == 0:
            break
        gid = struct.unpack("b", b[pos + 1:pos + 2])[0]
        ne = pos + 2 + nl
        out.append((pos, nl, gid, ne))
        off = struct.unpack(endian + "h", b[ne:ne + 2])[0]
        if off <= 0:
            break
        pos = ne + off
    return out


SPECIAL_F = [float("nan"), float("inf"), 0.0, -1e30, 1e30, -0.0, 1e-40, -1.0]
SPECIAL_W = [0, 1, 0x7FFF, 0xFFFF, 0x8000, 2, 255]


@st.composite
def c3d_mutation(draw):
    kind = draw(st.sampled_from(["truncate", "bytes", "word", "float", "record", "value",
                                 "zeros", "nan", "header_only", "huge_counts"]))
    return (kind, draw(st.integers(0, 2**31)), draw(st.sampled_from(SPECIAL_W)),
            draw(st.sampled_from(SPECIAL_F)), draw(st.integers(0, 10)))


def mutate_c3d(data: bytes, mutation) -> bytes:
    kind, n, word, fval, which = mutation
    rng = np.random.default_rng(n)
    b = bytearray(data)
    pstart, pend = 512, 512 * (b[0] + b[(b[0] - 1) * 512 + 2])
    dstart = (struct.unpack("<H", b[16:18])[0] - 1) * 512
    recs = records(data)
    if kind == "truncate":
        cut = [n % 512, pstart + n % max(1, pend - pstart), pend + n % max(1, len(b) - pend)]
        return bytes(b[: cut[which % 3]])
    if kind == "bytes":
        for i in rng.integers(0, min(len(b), pend), size=1 + n % 10):
            b[i] = int(rng.integers(0, 256))
    elif kind == "word":
        w = which % 12 if which else 1 + n % 11
        b[2 * w:2 * w + 2] = struct.pack("<H", word)
    elif kind == "float":
        off = (12, 20)[n % 2]
        b[off:off + 4] = struct.pack("<f", fval)
    elif kind == "record" and recs:
        pos, _nl, gid, ne = recs[n % len(recs)]
        body = ne + 2
        choice = which % 5
        if choice == 0:
            b[pos] = int(rng.integers(0, 256))
        elif choice == 1:
            b[pos + 1] = int(rng.integers(0, 256))
        elif choice == 2:
            b[ne:ne + 2] = struct.pack("<h", int(rng.choice([0, -1, 1, 2, 32767, -32768])))
        elif choice == 3 and gid > 0:
            b[body] = int(rng.integers(0, 256))
        elif gid > 0:
            b[body + 1] = int(rng.integers(0, 256))
    elif kind == "value" and recs:
        params = [r for r in recs if r[2] > 0]
        _pos, _nl, _gid, ne = params[n % len(params)]
        body = ne + 2
        d = body + 2 + b[body + 1]
        b[d:d + 4] = [struct.pack("<f", fval), struct.pack("<hh", -1, -1),
                      struct.pack("<hh", 32767, 32767), bytes(4)][which % 4]
    elif kind in ("zeros", "nan"):
        a = dstart + n % max(1, len(b) - dstart)
        c = min(len(b), a + 4 * (1 + n % 50000))
        fill = bytes(c - a) if kind == "zeros" else struct.pack("<f", np.nan) * ((c - a) // 4)
        b[a:a + len(fill)] = fill
    elif kind == "header_only":
        return bytes(b[:512])
    elif kind == "huge_counts":
        b[2:4] = struct.pack("<H", 0xFFFF)          # points per frame
        b[8:10] = struct.pack("<H", 0xFFFF)         # last frame
    return bytes(b)


@SETTINGS
@given(mutation=c3d_mutation(), seed=st.integers(0, 2))
def test_fuzzed_c3d_ends_cleanly(seeds, tmp_path_factory, mutation, seed):
    tmp = tmp_path_factory.mktemp("c3d")
    path = tmp / "fuzz.c3d"
    data = seeds["c3d"][seed % len(seeds["c3d"])]
    path.write_bytes(mutate_c3d(data, mutation))
    check_outcome(path)


# --------------------------------------------------------------------------------------------------
# Regressions found by the campaigns: each aborted the process inside ezc3d (SIGSEGV)


def _flip_group_id(data: bytes, record_name: bytes, new_gid: int) -> bytes:
    b = bytearray(data)
    for pos, nl, gid, ne in records(data):
        if data[pos + 2:ne] == record_name:
            b[pos + 1] = new_gid & 0xFF
            return bytes(b)
    raise AssertionError(f"no record {record_name!r}")


@pytest.mark.parametrize("trial, record, gid", [
    ("motionanalysis_btk_gait/Gait.c3d", b"Company", -101),
    ("qualisys_ezc3d/Qualisys.c3d", b"MATRIX_STORE", -69),
    ("vicon_c3dorg_sample09/PlugInC3D.c3d", b"ANGLES", -28),
])
def test_a_parameter_turned_into_a_group_is_refused_before_ezc3d(shared_data, tmp_path, trial,
                                                                  record, gid):
    data = (shared_data("gait_trials") / trial).read_bytes()
    path = tmp_path / "bad.c3d"
    path.write_bytes(_flip_group_id(data, record, gid))
    assert check_command(path, tmp_path / "out") == 2
    assert "corrupt parameter section" in run_gait(path, tmp_path / "out")[1]


def test_a_cut_parameter_section_is_refused_before_ezc3d(shared_data, tmp_path):
    # ANALOG:OFFSET's link set to 0 ends the section there: ANALOG:SCALE is never read, and
    # ezc3d scaled 28 channels with a missing scale (SIGSEGV)
    data = bytearray((shared_data("gait_trials") / "motionanalysis_btk_gait/Gait.c3d").read_bytes())
    *_, ne = next(r for r in records(bytes(data)) if data[r[0] + 2:r[3]] == b"OFFSET")
    data[ne:ne + 2] = b"\x00\x00"
    path = tmp_path / "cut.c3d"
    path.write_bytes(bytes(data))
    assert check_command(path, tmp_path / "out") == 2
    assert "ANALOG:SCALE holds 0 values for 28" in run_gait(path, tmp_path / "out")[1]


def test_the_seeds_themselves_are_read(seeds, tmp_path):
    for i, data in enumerate(seeds["c3d"][:1] + seeds["trc"]):
        suffix = ".c3d" if i == 0 else ".trc"
        path = tmp_path / f"seed{i}{suffix}"
        path.write_bytes(data)
        assert check_command(path, tmp_path / f"out{i}") == 0


def test_a_truncated_file_through_the_command(seeds, tmp_path):
    for i, data in enumerate((seeds["c3d"][0], seeds["trc"][0])):
        path = tmp_path / f"cut{i}{'.c3d' if i == 0 else '.trc'}"
        path.write_bytes(data[: len(data) // 2])
        assert check_command(path, tmp_path / f"out{i}") == 2


LONG = settings(SETTINGS, max_examples=1500)


@pytest.mark.slow
@LONG
@given(mutation=trc_mutation())
def test_fuzzed_trc_long(seeds, tmp_path_factory, mutation):
    test_fuzzed_trc_ends_cleanly.hypothesis.inner_test(seeds, tmp_path_factory, mutation)


@pytest.mark.slow
@LONG
@given(mutation=c3d_mutation(), seed=st.integers(0, 2))
def test_fuzzed_c3d_long(seeds, tmp_path_factory, mutation, seed):
    test_fuzzed_c3d_ends_cleanly.hypothesis.inner_test(seeds, tmp_path_factory, mutation, seed)
