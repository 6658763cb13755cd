"""``ipf-jax sweep``: config validation, stable cell ids, failure isolation, kill-and-resume.

Cells track a tiny self-rendered walk (2 cameras 160x120, the likelihood tests' shapes, chunk 64)
from a given initial pose, so a cell takes well under a second once compiled.
"""
import csv
import gc
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from ipf_jax.body import default_shape
from ipf_jax.cli import main
from ipf_jax.data.runfiles import JOINT_COLUMNS, POSE_COLUMNS, CsvAppender
from ipf_jax.errors import IPFError
from ipf_jax.sweep import backends, execute, load_config
from ipf_jax.sweep.summary import TIMING_COLUMNS, pareto_front
from ipf_jax.viz import synthetic as syn
from ipf_jax.viz.synthetic import write_dataset

N_FRAMES = 5
# fixed settings of every test cell: known up axis and height, small chunk, no re-initialisation
# (a tiny filter on a tiny scene would otherwise trigger the expensive search, not what we test)
FIXED = 'up_axis = "+z"\nheight_m = {h}\nchunk = 64\nconfidence_patience = 1000\n'


def write_scene(root: Path, n_frames: int = N_FRAMES) -> Path:
    """A walk rendered into a bodytrack-layout folder, its truth and its first pose."""
    shape = default_shape()
    cams = syn.ring_cameras(2, width=160, height=120, focal_px=150)
    q = syn.procedural_walk(n_frames, shape=shape)
    write_dataset(root / "walk", cams, syn.render_masks(q, shape, cams))
    truth = CsvAppender(root / "truth.csv", JOINT_COLUMNS)
    for t, pts in enumerate(syn.joints_of(q, shape)):
        truth.write(t, t / 20.0, pts.ravel())
    truth.close()
    pose = CsvAppender(root / "pose0.csv", POSE_COLUMNS)
    pose.write(0, 0.0, q[0])
    pose.close()
    return root


def write_config(root: Path, body: str, *, shared: str = "") -> Path:
    text = ("[sweep]\n" + FIXED.format(h=default_shape().height_m) + shared
            + '\n[[dataset]]\npath = "walk"\ntruth = "truth.csv"\ninit_pose = "pose0.csv"\n\n' + body)
    path = root / "sweep.toml"
    path.write_text(text)
    return path


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    return write_scene(tmp_path_factory.mktemp("scene"))


def read_summary(path: Path, drop=TIMING_COLUMNS) -> list[dict]:
    with open(path) as fh:
        return [{k: v for k, v in row.items() if k not in drop} for row in csv.DictReader(fh)]


# -- configuration ------------------------------------------------------------------------------
def test_cells_are_the_product_of_value_lists_with_stable_ids(scene):
    cfg = write_config(scene, '[[filter]]\nname = "ipf"\ninterval_width_deg = [5, 10.0, 20]\ntop_m = [1, 2]\n'
                              '[[filter]]\nname = "sir"\nparticles = [16, 32]\n', shared="seed = [0, 1]\n")
    cells = load_config(cfg).cells
    assert len(cells) == (3 * 2 + 2) * 2
    assert len({c.id for c in cells}) == len(cells)
    assert [c.id for c in load_config(cfg).cells] == [c.id for c in cells]  # stable across reads
    first = cells[0].spec
    assert first["options"] == {"interval_width_deg": 5.0, "top_m": 1}  # ints given for a float: 5.0
    assert first["track"]["seed"] == 0 and first["dataset"] == str(scene / "walk")
    assert cells[0].label == "walk ipf seed=0 interval_width_deg=5.0 top_m=1"
    # 10 and 10.0 are one setting: the cell keeps its id
    cfg2 = write_config(scene, '[[filter]]\nname = "ipf"\ninterval_width_deg = 10\ntop_m = 1\n', shared="seed = 0\n")
    assert load_config(cfg2).cells[0].id in {c.id for c in cells}


@pytest.mark.parametrize("body, message", [
    ('[[filter]]\nname = "ipf"\ntop_n = [1]\n', "unknown key(s) top_n"),
    ('[[filter]]\nname = "ipf"\ntop_m = ["ten"]\n', "top_m must be an integer"),
    ('[[filter]]\nname = "ipf"\ntop_m = []\n', "top_m is an empty list"),
    ('[[filter]]\nname = "ipf"\nlayers = [3]\n', "do not apply to the ipf filter"),
    ('[[filter]]\nname = "ipf"\nbudget = [10]\n', "cannot hold one grid"),
    ('[[filter]]\nname = "ukf"\n', "name must be one of ipf, fipf, apf, sir"),
    ('[[filter]]\nname = "sir"\nresolution = 8\n', "resolution must be 16..2048"),
    ('[[filter]]\nname = "sir"\nframes = "0-4"\n', "frames must be "),
    ('[[filter]]\nname = "sir"\nframes = "5:2"\n', "selects no frame"),
    ('[[filter]]\nname = "sir"\nseed = 99999999999999999999\n', "seed"),
    ('[[filter]]\nname = "sir"\n[[dataset]]\npath = "nowhere"\n', "dataset folder not found"),
    ('[[filter]]\nname = "sir"\n[eval]\nalign = "affine"\n', "align must be none or rigid"),
    ('[[filter]\nname = "sir"\n', "not a readable TOML file"),
    ('[[filter]]\nname = "sir"\n[[dataset]]\npath = "a\\u0000b"\n', "it holds a NUL character"),
    ('[[filter]]\nname = "sir"\n# caf\xe9\n', "not a readable TOML file"),
    ('[[filter]]\nname = "sir"\nframes = "1000:1002"\n', "walk: frames 1000:1002 selects none of the frames"),
    ('[[filter]]\nname = "sir"\n[[dataset]]\npath = "walk"\nname = "w2"\ntruth = "pose0.csv"\n',
     "w2: truth: "),
])
def test_config_mistakes_are_one_error_naming_the_file(scene, body, message):
    cfg = write_config(scene, body)
    if "\xe9" in body:  # the file in Latin-1, not UTF-8
        cfg.write_bytes(cfg.read_text().encode("latin-1"))
    with pytest.raises(IPFError) as e:
        load_config(cfg)
    assert message in str(e.value) and e.value.path == str(cfg)


def test_cli_config_error_is_one_line_and_runs_nothing(scene, tmp_path, capsys):
    cfg = write_config(scene, '[[filter]]\nname = "ipf"\nlayers = 3\n')
    assert main(["sweep", str(cfg), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"error: {cfg}: [[filter]] 1 (ipf)") and "\n" not in err
    assert not (tmp_path / "out").exists()
    cfg = write_config(scene, '[[filter]]\nname = "sir"\n')
    assert main(["sweep", str(cfg), "--out", str(tmp_path / "out"), "--address", "10.0.0.1:6379"]) == 2
    assert "--address joins a Ray cluster" in capsys.readouterr().err


def test_ray_without_cpus_is_refused_before_it_starts():
    """--num-cpus 0 started a local Ray whose cells never ran: the sweep hung."""
    for n in (0, -2):
        with pytest.raises(IPFError, match=rf"--num-cpus must be >= 1 \(got {n}\)"):
            backends.make_backend("ray", None, n)


def test_ray_backend_without_ray_says_how_to_install(monkeypatch):
    monkeypatch.setitem(sys.modules, "ray", None)  # as if the extra were not installed
    with pytest.raises(IPFError, match=r"pip install 'ipf-jax\[ray\]'"):
        backends.make_backend("ray")


def test_pareto_front():
    cost = np.array([1.0, 2.0, 3.0, 4.0, 2.0])
    err = np.array([50.0, 40.0, 45.0, 30.0, 60.0])
    assert pareto_front(cost, err).tolist() == [0, 1, 3]


# -- running ----------------------------------------------------------------------------------
def test_failing_cell_is_recorded_and_the_sweep_goes_on(scene, tmp_path, capsys):
    (scene / "broken").mkdir(exist_ok=True)  # a folder that is no dataset: fails when the cell runs
    cfg = write_config(scene, '[[dataset]]\npath = "broken"\n\n[[filter]]\nname = "ipf"\n'
                              'points_per_dof = 2\ntop_m = [1, 2]\n')
    out = tmp_path / "out"
    assert main(["sweep", str(cfg), "--out", str(out), "--quiet"]) == 1  # 1: some cells failed
    records = [json.loads(p.read_text()) for p in sorted((out / "cells").glob("*.json"))]
    assert sorted(r["status"] for r in records) == ["failed", "failed", "ok", "ok"]
    bad = [r for r in records if r["status"] == "failed"][0]
    assert bad["error"]["type"] == "IPFError" and "unknown dataset layout" in bad["error"]["message"]
    good = [r for r in records if r["status"] == "ok"][0]
    assert good["result"]["evaluations_per_frame"] == good["settings"]["options"]["top_m"] * 16
    assert 0 < good["result"]["mpjpe_m"] < 0.2 and good["result"]["n_frames"] == N_FRAMES
    assert len(good["code"]) == 16  # fingerprint of the ipf_jax sources that computed it
    assert good["timing"]["seconds_per_frame"] > 0
    status = json.loads((out / "summary.json").read_text())
    assert (status["succeeded"], status["failed"]) == (2, 2)
    printed = capsys.readouterr().out
    assert "2 succeeded, 2 failed" in printed and "unknown dataset layout" in printed
    assert (out / "pareto.png").exists()
    rows = read_summary(out / "summary.csv")
    assert [r["status"] for r in rows] == ["ok", "ok", "failed", "failed"]  # config order
    assert "unknown dataset layout" in rows[2]["error"] and rows[0]["top_m"] == "1"
    # a rerun skips every recorded cell, failed ones too, unless asked to retry them
    calls = []
    original = backends.execute
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(backends, "execute", lambda spec, d: calls.append(spec["name"]) or original(spec, d))
        assert main(["sweep", str(cfg), "--out", str(out), "--quiet"]) == 1
        assert calls == []
        assert main(["sweep", str(cfg), "--out", str(out), "--quiet", "--retry-failed"]) == 1
        assert calls == ["broken", "broken"]
    # a cell computed by other sources (e.g. resumed after an update) is pointed out
    path = out / "cells" / f"{good['id']}.json"
    path.write_text(json.dumps({**good, "code": "0" * 16}))
    capsys.readouterr()
    assert main(["sweep", str(cfg), "--out", str(out), "--quiet"]) == 1
    assert "computed by 2 different versions of ipf_jax" in capsys.readouterr().err


def test_a_bug_in_a_cell_is_recorded_with_its_traceback(scene, tmp_path, monkeypatch):
    import ipf_jax.tracking.passes

    def broken(*args, **kwargs):
        raise ZeroDivisionError("deliberate")

    monkeypatch.setattr(ipf_jax.tracking.passes, "track", broken)
    cell = load_config(write_config(scene, '[[filter]]\nname = "sir"\n')).cells[0]
    record = execute(cell.spec, tmp_path / "run")
    assert record["status"] == "failed" and record["result"] is None
    assert record["error"]["type"] == "ZeroDivisionError" and "deliberate" in record["error"]["traceback"]


def test_killed_sweep_resumes_without_recomputing_finished_cells(scene, tmp_path, monkeypatch):
    cfg = write_config(scene, '[[filter]]\nname = "ipf"\npoints_per_dof = 2\ntop_m = [1, 2, 3]\n',
                       shared="seed = [0, 1]\n")
    n_cells = len(load_config(cfg).cells)
    killed = tmp_path / "killed"
    proc = subprocess.Popen([sys.executable, "-m", "ipf_jax.cli.main", "sweep", str(cfg), "--out", str(killed),
                             "--quiet"], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=os.environ.copy())
    deadline = time.monotonic() + 300
    try:
        while not list((killed / "cells").glob("*.json")) and time.monotonic() < deadline:
            assert proc.poll() is None, proc.stderr.read().decode()
            time.sleep(0.02)
    finally:
        proc.kill()
        proc.wait()
    finished = {p: p.stat().st_mtime_ns for p in (killed / "cells").glob("*.json")}
    assert 1 <= len(finished) < n_cells, "the kill came too late to test resuming"
    runs = {p: p.stat().st_mtime_ns for p in (killed / "runs").glob("*/joints.csv")
            if (killed / "cells" / f"{p.parent.name}.json").exists()}

    calls = []
    original = backends.execute
    monkeypatch.setattr(backends, "execute", lambda spec, d: calls.append(Path(d).name) or original(spec, d))
    assert main(["sweep", str(cfg), "--out", str(killed), "--quiet"]) == 0
    assert len(calls) == n_cells - len(finished)
    assert not {Path(c) for c in calls} & {Path(p.stem) for p in finished}
    assert {p: p.stat().st_mtime_ns for p in finished} == finished  # records untouched
    assert {p: p.stat().st_mtime_ns for p in runs} == runs  # and their runs not redone

    whole = tmp_path / "whole"
    assert main(["sweep", str(cfg), "--out", str(whole), "--quiet"]) == 0
    assert read_summary(killed / "summary.csv") == read_summary(whole / "summary.csv")
    assert len(json.loads((killed / "summary.json").read_text())["code_versions"]) == 1
    assert len(read_summary(whole / "summary.csv")) == n_cells
    for p in (whole / "cells").glob("*.json"):  # same seeds -> same results, cell by cell
        assert json.loads(p.read_text())["result"] == json.loads((killed / "cells" / p.name).read_text())["result"]


def test_release_compiled_frees_memory_maps_past_the_share():
    import jax
    import jax.numpy as jnp

    from ipf_jax import jax_setup

    if jax_setup.map_usage() is None:
        pytest.skip("no /proc memory-map counts here")
    f = jax.jit(lambda x: jnp.cos(x) * 3 - x.max())
    for n in range(1, 41):
        f(jnp.ones(n)).block_until_ready()
    gc.collect()  # garbage of earlier tests (large arrays are maps of their own) goes first
    used, limit = jax_setup.map_usage()
    # under the limit nothing is cleared (the process's map count itself may drift by a few
    # maps as memory is returned: 9 in a full run, so the programs are counted instead)
    assert not jax_setup.release_compiled(share=1.0)
    assert f._cache_size() == 40
    assert jax_setup.release_compiled(share=0.0)
    assert f._cache_size() == 0
    assert jax_setup.map_usage()[0] < used - 40  # 40 programs' mappings are gone
