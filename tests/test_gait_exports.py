"""``ipf-jax gait`` on ipf-jax's own joints.csv, TRC and C3D exports of one run, with no map.

The run directory is built with :func:`ipf_jax.analysis.export.write_run_dir` from a procedural walk (no
tracking); the exports are made with :mod:`ipf_jax.analysis.export`. All three files must give the same
events within 1 ms. A run made with one camera must report step width as not observable instead
of giving numbers.
"""
from __future__ import annotations

import csv
import json

import numpy as np
import pytest

from ipf_jax.analysis.export import export_c3d, export_trc, read_run, write_run_dir
from ipf_jax.analysis.gait import analyse, load
from ipf_jax.body.shape import default_shape
from ipf_jax.cli import gait as gait_cli
from ipf_jax.viz.synthetic import procedural_walk

FORMATS = ("joints.csv", "walk.trc", "walk.c3d")


def _run(tmp_path, *, fps: float, cameras: list, first_frame: int = 7):
    shape = default_shape()
    q = procedural_walk(int(4 * fps), fps, shape=shape, up_axis="+z", heading_deg=30.0)
    q[len(q) // 3] = np.nan  # a lost frame, as the tracker writes it
    run_dir = write_run_dir(tmp_path / "run", q, shape=shape, up_axis="+z", fps=fps,
                            frames=np.arange(len(q)) + first_frame, meta={"cameras": cameras})
    run = read_run(run_dir)
    export_trc(run, run_dir / "walk.trc")            # +y up, mm (OpenSim convention)
    export_c3d(run, run_dir / "walk.c3d")            # world frame (+z), mm
    return run_dir


@pytest.mark.parametrize("fps, method", [(20.0, "zeni"), (100.0, "contact")])
def test_joints_trc_and_c3d_give_the_same_events(tmp_path, fps, method):
    run_dir = _run(tmp_path, fps=fps, cameras=["Camera1", "Camera2", "Camera3", "Camera4"])
    results = {f: analyse(load(run_dir / f)) for f in FORMATS}
    ref = results["joints.csv"]
    assert ref.method == method
    assert sum(len(v) for v in ref.events.values()) >= 12
    for name in FORMATS[1:]:
        res = results[name]
        assert any("ipf-jax" in n for n in res.notes), res.notes  # recognised, no map given
        for ev, times in ref.events.items():
            assert res.events[ev].shape == times.shape, (name, ev)
            np.testing.assert_allclose(res.events[ev], times, atol=1e-3, err_msg=f"{name} {ev}")
        assert res.lab["cadence_steps_per_min"] == pytest.approx(
            ref.lab["cadence_steps_per_min"], abs=0.1)
    # the TRC is +y up (export default), the C3D keeps the run's +z: read from the body / file
    assert results["walk.trc"].up_axis == "+y" and results["walk.c3d"].up_axis == "+z"
    # the run's clock is kept: frame 7 at 20 Hz is 0.35 s
    assert min(min(v) for v in ref.events.values() if len(v)) > 7 / fps


def test_one_camera_flags_step_width_as_not_observable(tmp_path):
    run_dir = _run(tmp_path, fps=20.0, cameras=["Camera4"])
    out = tmp_path / "gait"
    args = _parse(["gait", str(run_dir / "joints.csv"), "--out", str(out)])
    assert gait_cli.run(args) == 0
    doc = json.loads((out / "gait.json").read_text())
    assert doc["cameras"] == 1 and "step_width_m" in doc["unobservable"]
    assert doc["parameters"]["step_width_m"]["all"]["mean"] is None
    assert doc["fall_risk"]["step_width_sd_m"]["value"] is None
    assert "not observable" in doc["fall_risk"]["step_width_sd_m"]["note"]
    rows = list(csv.DictReader((out / "steps.csv").open()))
    assert rows and all(r["step_width_m"] == "nan" for r in rows)
    assert doc["parameters"]["step_length_m"]["all"]["mean"] > 0.4  # still measured
    page = (out / "report.html").read_text()
    assert "Not observable with these cameras" in page and "step_width_m" in page
    # the same run seen by four cameras gives step widths
    many = analyse(load(run_dir / "joints.csv", cameras=4))
    assert many.parameters["step_width_m"]["all"]["mean"] is not None


def _parse(argv):
    import argparse

    parser = argparse.ArgumentParser(prog="ipf-jax")
    gait_cli.add_parser(parser.add_subparsers(dest="command", required=True))
    return parser.parse_args(argv)
