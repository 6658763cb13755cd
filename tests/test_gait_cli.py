"""The ``ipf-jax gait`` command: ``add_parser`` + ``run(args)`` write every output file."""
from __future__ import annotations

import argparse
import csv
import json

import numpy as np
import pytest

from ipf_jax.cli import gait as cli


def _parse(argv):
    parser = argparse.ArgumentParser(prog="ipf-jax")
    cli.add_parser(parser.add_subparsers(dest="command", required=True))
    return parser.parse_args(argv)


def test_run_on_the_real_trc_writes_all_outputs(shared_data, tmp_path, capsys):
    trc = shared_data("opensim_walk/Rajagopal") / "motion_capture_walk.trc"
    out = tmp_path / "gait"
    assert cli.run(_parse(["gait", str(trc), "--out", str(out)])) == 0
    assert "heel strikes" in capsys.readouterr().out
    for name in ("gait.json", "steps.csv", "strides.csv", "displacement.png", "angles.png",
                 "variability.png", "report.html"):
        assert (out / name).is_file() and (out / name).stat().st_size > 0, name
    doc = json.loads((out / "gait.json").read_text())
    assert doc["format"] == "ipf-jax-gait" and doc["method"] == "contact"  # auto at 100 fps
    for key in ("direction", "segments", "events", "parameters", "missing", "curves", "filter",
                "fall_risk", "lab", "rejected", "bounds"):
        assert key in doc
    assert set(doc["events"]) == {"left_heel_strike", "right_heel_strike", "left_toe_off",
                                  "right_toe_off"}
    # TRC clock: the plates' first right contact is at 0.268 s
    assert min(doc["events"]["right_heel_strike"]) == pytest.approx(0.268, abs=0.02)
    assert doc["direction"]["mode"] == "overground"
    assert doc["direction"]["forward"][0] > 0.99  # walking along +X
    assert len(doc["curves"]["left"]["knee_flexion_deg"]["mean"]) == 101
    rows = list(csv.DictReader((out / "steps.csv").open()))
    assert len(rows) == doc["counts"]["steps"] == 3
    lengths = [float(r["step_length_m"]) for r in rows]
    assert np.mean(lengths) == pytest.approx(doc["parameters"]["step_length_m"]["all"]["mean"])
    for png in ("displacement.png", "angles.png", "variability.png"):
        assert (out / png).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    page = (out / "report.html").read_text()
    assert page.count("data:image/png;base64,") == 3
    assert "Balance and fall risk" in page and "World guidelines for falls" in page
    assert "http" not in page  # self-contained


def test_run_with_options_and_velocity_method(shared_data, tmp_path):
    gt = shared_data("mocap_walk_render/rajagopal_walk_clean_4cam") / "ground_truth.csv"
    out = tmp_path / "gt"
    args = _parse(["gait", str(gt), "--out", str(out), "--up", "+z", "--method", "velocity",
                   "--cutoff", "4"])
    assert cli.run(args) == 0
    doc = json.loads((out / "gait.json").read_text())
    assert doc["method"] == "velocity" and doc["filter"]["cutoff_hz"] == 4.0
    assert doc["stand_ins"] == {"left_heel": "left_ankle", "right_heel": "right_ankle"}
    assert "stride_time_s.left" in doc["missing"]  # 1.55 s: no complete left stride
    assert not (out / "angles.png").exists()  # no complete stride -> no cycle curves


def test_run_reports_a_bad_input_on_one_line(tmp_path, capsys):
    missing = tmp_path / "nothere.trc"
    assert cli.run(_parse(["gait", str(missing), "--out", str(tmp_path / "o")])) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: ") and "nothere.trc" in err[0]
    assert not (tmp_path / "o").exists()


def test_parser_rejects_unknown_method():
    with pytest.raises(SystemExit):
        _parse(["gait", "x.trc", "--out", "o", "--method", "magic"])
