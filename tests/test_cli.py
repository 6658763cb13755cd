"""The CLI imports only the invoked command's module, and every listed command parses."""
import argparse
import importlib
import subprocess
import sys

import pytest

from ipf_jax.cli.main import MODULE_COMMANDS, _parser


@pytest.mark.parametrize("name", list(MODULE_COMMANDS))
def test_each_listed_command_is_registered_by_its_module(name):
    module, _ = MODULE_COMMANDS[name]
    sub = argparse.ArgumentParser().add_subparsers(dest="command")
    importlib.import_module(module).add_parser(sub)
    assert name in sub.choices
    p = _parser([name, "--help"])
    action = next(a for a in p._actions if isinstance(a, argparse._SubParsersAction))
    assert action.choices[name].add_help  # the real parser, not the --help placeholder


def test_help_does_not_import_the_heavy_modules():
    code = ("import sys; from ipf_jax.cli.main import _parser; _parser(['--help']); "
            "print(','.join(m for m in ('jax', 'scipy', 'matplotlib') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == ""


def test_floor_range_reaches_track_and_batch_settings(tmp_path):
    from ipf_jax.cli.options import floor_range
    from ipf_jax.cli.sweep import settings_from_args
    from ipf_jax.sweep.batch import batch_cells
    from ipf_jax.sweep.spec import track_settings

    args = _parser(["track"]).parse_args(["track", "ds", "--out", "o", "--floor-range=-0.03,0.10"])
    assert floor_range(args) == (-0.03, 0.10)
    assert floor_range(_parser(["track"]).parse_args(["track", "ds", "--out", "o"])) is None
    (tmp_path / "walk").mkdir()
    (tmp_path / "m.txt").write_text("walk\n")
    args = _parser(["batch"]).parse_args(["batch", str(tmp_path / "m.txt"), "--out", "o",
                                          "--floor-range=-0.02,0.05"])
    cell = batch_cells(tmp_path / "m.txt", settings_from_args(args, tmp_path))[0]
    assert track_settings(cell.spec).floor_range == (-0.02, 0.05)
    plain = _parser(["batch"]).parse_args(["batch", str(tmp_path / "m.txt"), "--out", "o"])
    assert batch_cells(tmp_path / "m.txt", settings_from_args(plain, tmp_path))[0].id != cell.id


def test_resume_with_a_missing_csv_is_refused(tmp_path):
    from ipf_jax.data.runfiles import CsvAppender
    from ipf_jax.errors import IPFError

    with pytest.raises(IPFError, match="cannot resume: the file is missing"):
        CsvAppender(tmp_path / "poses.csv", ["frame", "time_s", "a"], keep_rows=5, lazy=True)
    CsvAppender(tmp_path / "fresh.csv", ["frame", "time_s", "a"], keep_rows=0, lazy=True).close()
