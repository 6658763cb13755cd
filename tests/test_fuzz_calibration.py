"""Property tests: every calibration format and dataset.json, damaged (truncated, wrong types,
NaN/inf, huge values, empty, wrong sizes, stray bytes), ends in one IPFError naming the file, or
is read whole (a harmless change) - never another exception; and a failed command leaves nothing."""
from __future__ import annotations

import json
import os
import re
import shutil
import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from ipf_jax.cli import main
from ipf_jax.data.calibration import read_calibration, write_json
from ipf_jax.data.calibration_formats import (
    write_optitrack,
    write_qualisys,
    write_vicon,
)
from ipf_jax.data.dataset import open_dataset
from ipf_jax.errors import IPFError
from ipf_jax.geometry.camera import Camera

BAD_NUMBERS = ["nan", "NaN", "inf", "-inf", "1e400", "-1e308", "0", "-0", "", "abc", "1e-400",
               "99999999999999999999999", "1,5", "--1", "0x10", "true", "null", "[]", "1 2"]
FUZZ = settings(max_examples=int(os.environ.get("IPF_FUZZ_EXAMPLES", "40")), deadline=None,
                derandomize=os.environ.get("IPF_FUZZ_EXAMPLES") is None,
                suppress_health_check=[HealthCheck.function_scoped_fixture,
                                       HealthCheck.too_slow])
_NUM = re.compile(r"-?\d+(\.\d+)?([eE][-+]?\d+)?")


def _cams(shared_data):
    return __import__("ipf_jax.data.calibration", fromlist=["x"]).read_calibration(
        shared_data("mocap_walk_render/rajagopal_walk_clean_4cam") / "CALIB")


@pytest.fixture(scope="module")
def seeds(shared_data, tmp_path_factory):
    """name -> (file name, valid text) for every format."""
    d = tmp_path_factory.mktemp("seeds")
    cams = _cams(shared_data)
    out = {"cal": ("Camera1.cal", (shared_data("parsec_bodytrack/sequenceB_2") / "CALIB"
                                   / "Camera1.cal").read_text()),
           "opencv": ("config.xml", (shared_data("uu_4cam_background") / "cam1"
                                     / "config.xml").read_text()),
           "toml": ("Calib.toml", (shared_data("sports2d_walk") / "Calib_demo.toml").read_text())}
    write_json(cams, d / "cameras.json")
    write_qualisys(cams, d / "c.qca.txt")
    write_vicon(cams, d / "c.xcp")
    write_optitrack(cams, d / "c.mcal", encoding="utf-8")
    out["json"] = ("cameras.json", (d / "cameras.json").read_text())
    out["qualisys"] = ("Calib.qca.txt", (d / "c.qca.txt").read_text())
    out["vicon"] = ("calib.xcp", (d / "c.xcp").read_text())
    out["optitrack"] = ("System Calibration.mcal", (d / "c.mcal").read_text())
    return out


def _mutate(text: str, data) -> str:
    kind = data.draw(st.sampled_from(["truncate", "number", "drop_line", "dup_line", "bytes",
                                      "empty", "swap_tag"]))
    if kind == "truncate":
        return text[:data.draw(st.integers(0, len(text)))]
    if kind == "number":
        nums = list(_NUM.finditer(text))
        if not nums:
            return text + "nan"
        m = nums[data.draw(st.integers(0, len(nums) - 1))]
        return text[:m.start()] + data.draw(st.sampled_from(BAD_NUMBERS)) + text[m.end():]
    lines = text.splitlines(keepends=True)
    if kind == "drop_line" and lines:
        del lines[data.draw(st.integers(0, len(lines) - 1))]
        return "".join(lines)
    if kind == "dup_line" and lines:
        i = data.draw(st.integers(0, len(lines) - 1))
        return "".join(lines[:i + 1] + lines[i:])
    if kind == "bytes":
        i = data.draw(st.integers(0, len(text)))
        junk = data.draw(st.text(min_size=1, max_size=8))
        return text[:i] + junk + text[i:]
    if kind == "empty":
        return data.draw(st.sampled_from(["", " ", "\n\n", "\x00" * 16]))
    return text.replace("<", "<x", 1) if "<" in text else text.replace("[", "{", 1)


def _read_all(path: Path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return read_calibration(path, 640, 480)


def _expect_clean(path: Path, fn):
    try:
        out = fn(path)
    except IPFError as e:
        assert e.path is not None and Path(e.path).name in (path.name, path.parent.name), e
        assert "\n" not in e.message and len(e.message) < 600, e.message
        return None
    return out


@pytest.mark.parametrize("fmt", ["cal", "opencv", "toml", "json", "qualisys", "vicon",
                                 "optitrack"])
@FUZZ
@given(data=st.data())
def test_damaged_calibration_is_one_clear_error(seeds, tmp_path, fmt, data):
    name, text = seeds[fmt]
    path = tmp_path / name
    path.write_text(_mutate(text, data), errors="surrogateescape")
    cams = _expect_clean(path, _read_all)
    if cams is not None:  # read whole: every camera is finite and usable
        assert cams and all(isinstance(c, Camera) and np.isfinite(c.K).all() for c in cams)


def test_huge_calibration_is_refused_before_reading(tmp_path):
    path = tmp_path / "Calib.qca.txt"
    with path.open("wb") as f:
        f.write(b"<calibration>")
        f.seek(40 << 20)
        f.write(b"</calibration>")
    with pytest.raises(IPFError, match="too large for a calibration"):
        read_calibration(path)


@pytest.fixture(scope="module")
def dataset_seed(shared_data, tmp_path_factory):
    """A dataset folder (masks of a render, cameras.json) and its valid dataset.json."""
    src = shared_data("mocap_walk_render/rajagopal_walk_clean_4cam")
    d = tmp_path_factory.mktemp("ds")
    for k in (1, 2):
        (d / f"FG{k}").mkdir()
        for f in sorted((src / f"FG{k}").glob("image000[0-1].png")):
            shutil.copy(f, d / f"FG{k}" / f.name)
    write_json(_cams(shared_data)[:2], d / "cameras.json")
    doc = {"calibration": "cameras.json", "fps": 20, "up_axis": "+z", "frames": "0:2",
           "segmentation": {"cover": 0.9}, "cameras": [
               {"name": "Camera1", "masks": "FG1", "roi": [0, 0, 640, 480]},
               {"name": "Camera2", "masks": "FG2", "crop": ["right"]}]}
    return d, doc


VALUES = st.one_of(st.none(), st.booleans(), st.integers(-10**20, 10**20),
                   st.sampled_from([float("nan"), float("inf"), -float("inf"), 1e308, -0.0, 0.5]),
                   st.text(max_size=6), st.lists(st.integers(-5, 700), max_size=5),
                   st.just({}), st.just({"x": 1}))


def _paths(doc, prefix=()):
    if isinstance(doc, dict):
        for k, v in doc.items():
            yield prefix + (k,)
            yield from _paths(v, prefix + (k,))
    elif isinstance(doc, list):
        for i, v in enumerate(doc):
            yield prefix + (i,)
            yield from _paths(v, prefix + (i,))


@FUZZ
@given(data=st.data())
def test_damaged_dataset_json_is_one_clear_error(dataset_seed, data):
    folder, base = dataset_seed
    doc = json.loads(json.dumps(base))
    paths = list(_paths(doc))
    for _ in range(data.draw(st.integers(1, 3))):
        where = data.draw(st.sampled_from(paths))
        delete, value = data.draw(st.booleans()), data.draw(VALUES)  # drawn whatever happens
        parent = doc
        try:
            for key in where[:-1]:
                parent = parent[key]
            if delete and isinstance(parent, dict):
                parent.pop(where[-1], None)
            else:
                parent[where[-1]] = value
        except (IndexError, KeyError, TypeError):
            pass  # an earlier change removed that place
    text = json.dumps(doc)
    cut = data.draw(st.integers(0, 5)) == 0
    at = data.draw(st.integers(0, 10**6))
    if cut:
        text = text[:at % (len(text) + 1)]
    (folder / "dataset.json").write_text(text)

    def opened(path):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            ds = open_dataset(path)
            return [m.shape for m in ds.masks(ds.frames[0])]
    try:
        opened(folder)
    except IPFError as e:
        assert e.path is not None and "\n" not in e.message, e


def test_init_dataset_with_a_broken_calibration_leaves_nothing(shared_data, tmp_path, capsys):
    src = shared_data("mocap_walk_render/rajagopal_walk_clean_4cam")
    bad = tmp_path / "Calib.qca.txt"
    bad.write_text("<calibration><cameras><camera serial='1'>")
    out = tmp_path / "out"
    rc = main(["init-dataset", str(src / "FG1"), "--masks", "--calibration", str(bad), "--out",
               str(out)])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and "Traceback" not in err and "\n" not in err and str(bad) in err
    assert not out.exists()
