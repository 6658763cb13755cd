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
    from ipf_jax.cli.options import settings_from_args as track_settings_from_args
    from ipf_jax.cli.sweep import settings_from_args
    from ipf_jax.sweep.batch import batch_cells
    from ipf_jax.sweep.spec import track_settings

    args = _parser(["track"]).parse_args(["track", "ds", "--out", "o", "--floor-range=-0.03,0.10"])
    assert track_settings_from_args(args).floor_range == (-0.03, 0.10)
    plain = _parser(["track"]).parse_args(["track", "ds", "--out", "o"])
    assert track_settings_from_args(plain).floor_range is None
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


def test_resume_refuses_a_kept_row_cut_short_and_drops_one_past_the_checkpoint(tmp_path):
    """Only whole rows count: a kept row without its newline (a file cut after the run stopped)
    would take the next row onto its line."""
    from ipf_jax.data.runfiles import CsvAppender
    from ipf_jax.errors import IPFError

    cols = ["frame", "time_s", "a"]
    path = tmp_path / "poses.csv"
    path.write_text("frame,time_s,a\n0,0.0,1.0\n1,0.05,2.0\n2,0.1,3")  # row 2 cut short
    with pytest.raises(IPFError, match="has 2 whole rows, the checkpoint needs 3"):
        CsvAppender(path, cols, keep_rows=3)
    app = CsvAppender(path, cols, keep_rows=2)  # the cut row is past the checkpoint: dropped
    app.write(2, 0.1, [3.0])
    app.close()
    assert path.read_text().splitlines()[1:] == ["0,0.0,1.0", "1,0.05,2.0", "2,0.100000,3.000000"]


def _all_parsers():
    """Every command's parser, built for real (not the --help placeholders)."""
    out = {}
    for name in MODULE_COMMANDS:
        p = _parser([name, "--help"])
        action = next(a for a in p._actions if isinstance(a, argparse._SubParsersAction))
        out[name] = action.choices[name]
    return out


def test_every_option_of_every_command_has_a_help_text():
    missing = [f"{name} {a.option_strings[0] if a.option_strings else a.dest}"
               for name, p in _all_parsers().items() for a in p._actions
               if not isinstance(a, argparse._HelpAction) and not (a.help or "").strip()]
    assert not missing, f"options without help: {missing}"


def test_track_help_documents_every_tracking_option():
    from ipf_jax.tracking.options import OPTIONS

    text = _all_parsers()["track"].format_help()
    assert all(o.flag in text for o in OPTIONS)


def test_each_long_flag_is_spelled_in_one_module_only():
    import ast
    import re
    from collections import defaultdict
    from pathlib import Path

    root = Path(__file__).resolve().parent.parent / "ipf_jax"
    where = defaultdict(set)
    for path in root.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Constant) and isinstance(node.value, str) \
                    and re.fullmatch(r"--[a-z][a-z0-9-]*", node.value):
                where[node.value].add(str(path.relative_to(root)))
    twice = {flag: sorted(mods) for flag, mods in where.items() if len(mods) > 1}
    assert not twice, f"flags declared in more than one module: {twice}"
    assert "--top-m" in where and "--out" in where  # the scan sees the declarations


def test_no_function_longer_than_80_lines():
    import ast
    from pathlib import Path

    root = Path(__file__).resolve().parent.parent / "ipf_jax"
    long = [f"{p.relative_to(root)}:{n.lineno} {n.name} ({n.end_lineno - n.lineno + 1} lines)"
            for p in root.rglob("*.py") for n in ast.walk(ast.parse(p.read_text()))
            if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef))
            and n.end_lineno - n.lineno + 1 > 80]
    assert not long, f"functions over 80 lines: {long}"


def _one_error(argv, capsys) -> str:
    from ipf_jax.cli import main

    code = main(argv)
    lines = [x for x in capsys.readouterr().err.splitlines() if x.strip()]
    assert code == 2 and len(lines) == 1 and lines[0].startswith("error: "), (code, lines)
    return lines[0]


def test_output_files_and_zero_values_are_checked_before_any_work(tmp_path, capsys):
    """An output file that is a folder, an empty name, and 0 for --fps / --resolution (which are
    not "not given") are refused up front, by the commands that write one file."""
    (tmp_path / "poses.csv").write_text("x\n")
    folder = tmp_path / "a_folder"
    folder.mkdir()
    score = ["score", str(tmp_path / "no_dataset"), "--frame", "0", "--poses", str(tmp_path / "poses.csv")]
    assert "is a folder" in _one_error([*score, "--out", str(folder)], capsys)
    assert "--out is empty" in _one_error([*score, "--out", ""], capsys)
    assert "--resolution 0" in _one_error([*score, "--resolution", "0", "--out", str(tmp_path / "s.json")],
                                          capsys)
    assert "is a folder" in _one_error(["bench", "--quick", "--json", str(folder)], capsys)
    assert "particles" in _one_error(["bench", "--quick", "--particles", "0", "--json",
                                      str(tmp_path / "b.json")], capsys)
    for flag in ("--threads", "--chunk"):  # refused before anything is timed
        assert f"{flag} 0" in _one_error(["bench", "--quick", flag, "0", "--json",
                                          str(tmp_path / "b.json")], capsys)
    reference = ["--quick", "--backends", "numpy-reference"]
    for extra, said in (([*reference, "--reference-particles", "0"], ">= 1"),
                        (["--quick", "--numpy-particles", "-1"], ">= 1"),  # were timed: 0 poses/s
                        # no cap: a typo's 10^8 particles ran out of memory mid-bench
                        (["--quick", "--particles", "100000000"], "100000000 particles in one measure step"),
                        (["--quick", "--backends", ","], "--backends names no value"),  # 0 records
                        # nothing at all (the start records alone would still be a bench)
                        (["--widths", ",", "--track-widths", ",", "--start-sets", ","],
                         "--widths names no value"),
                        (["--cameras", "9", "--track-widths", ","], "--cameras 9: the data set has 4")):
        assert said in _one_error(["bench", *extra, "--json", str(tmp_path / "b.json")], capsys)
    assert not (tmp_path / "b.json").exists()
    assert "--fps 0" in _one_error(["render", str(tmp_path), "--out", str(tmp_path / "v.mp4"),
                                    "--fps", "0"], capsys)
    # time_s keeps 6 decimals: a frame rate beyond 10 kHz would write every row at one time
    assert "must be 0.01..10000 Hz" in _one_error(["track", str(tmp_path), "--out", str(tmp_path / "t"),
                                                   "--fps", "1e9"], capsys)
    assert "--seed" in _one_error(["demo", "--seed", "-1", "--out", str(tmp_path / "demo")], capsys)
    assert not (tmp_path / "demo").exists()  # refused before anything was rendered


def test_score_refuses_a_height_that_disagrees_with_the_shape_file(tmp_path, capsys):
    import json

    from ipf_jax.body import default_shape
    from ipf_jax.tracking.shape_fit import shape_doc

    (tmp_path / "shape.json").write_text(json.dumps(shape_doc(default_shape(1.80), "test", None)))
    line = _one_error(["score", str(tmp_path), "--frame", "0", "--poses", str(tmp_path / "p.csv"),
                       "--shape", str(tmp_path / "shape.json"), "--height", "1.5",
                       "--out", str(tmp_path / "s.json")], capsys)
    assert "disagrees with the shape file's height_m 1.800" in line


def test_init_dataset_and_compare_check_their_values_before_any_work(tmp_path, capsys):
    init = ["init-dataset", str(tmp_path / "a"), str(tmp_path / "b"), "--calibration",
            str(tmp_path / "c.json"), "--masks", "--out", str(tmp_path / "ds")]
    assert "--names lists A more than once" in _one_error([*init, "--names", "A,A"], capsys)
    assert "--fps -5.0" in _one_error([*init, "--fps", "-5"], capsys)
    assert "--up" in _one_error([*init, "--up", "q"], capsys)
    assert not (tmp_path / "ds").exists()
    assert "--peer-seconds -1.0 needs --peer" in _one_error(
        ["compare", str(tmp_path), "--budget", "100", "--out", str(tmp_path / "cmp"),
         "--peer-seconds", "-1"], capsys)
    from ipf_jax.body import default_shape
    from ipf_jax.viz import synthetic as syn

    cams = syn.ring_cameras(2, width=80, height=60, focal_px=75)
    walk = syn.write_dataset(tmp_path / "walk", cams, syn.render_masks(
        syn.procedural_walk(2, shape=default_shape(1.75)), default_shape(1.75), cams))
    compare = ["compare", str(walk), "--budget", "100", "--out", str(tmp_path / "cmp")]
    assert "--peer-shape s.txt needs --peer" in _one_error([*compare, "--peer-shape", "s.txt"], capsys)
    assert "nope.txt: bodytrack poses file not found" in _one_error([*compare, "--peer", "nope.txt"], capsys)
    assert not (tmp_path / "cmp").exists()


def test_export_of_a_run_without_a_tracked_frame_is_refused(tmp_path, capsys):
    from ipf_jax.data.runfiles import JOINT_COLUMNS

    run = tmp_path / "run"
    run.mkdir()
    nan_row = ",".join(["nan"] * (len(JOINT_COLUMNS) - 2))
    (run / "joints.csv").write_text(",".join(JOINT_COLUMNS) + "\n" + f"0,0.0,{nan_row}\n1,0.05,{nan_row}\n")
    (run / "run.json").write_text('{"fps": 20.0, "up_axis": "+z"}')
    for fmt in ("trc", "c3d"):
        line = _one_error(["export", str(run), "--format", fmt, "--out", str(tmp_path / f"x.{fmt}")], capsys)
        assert "no tracked frame to export" in line
        assert not (tmp_path / f"x.{fmt}").exists()



def test_export_never_overwrites_the_run_it_reads(tmp_path, capsys):
    """--out RUN/joints.csv replaced the run's own joints with the export (mm columns, other axes);
    --out a folder left a stray FILE.tmp."""
    from ipf_jax.data.runfiles import JOINT_COLUMNS

    run = tmp_path / "run"
    run.mkdir()
    row = ",".join(["0.5"] * (len(JOINT_COLUMNS) - 2))
    joints = ",".join(JOINT_COLUMNS) + "\n" + f"0,0.0,{row}\n1,0.05,{row}\n"
    (run / "joints.csv").write_text(joints)
    (run / "run.json").write_text('{"fps": 20.0, "up_axis": "+z"}')
    for name in ("joints.csv", "run.json"):
        line = _one_error(["export", str(run), "--format", "csv", "--units", "mm", "--out", str(run / name)],
                          capsys)
        assert f"{name}: is one of the run's own files" in line
    assert (run / "joints.csv").read_text() == joints
    assert "is a folder" in _one_error(["export", str(run), "--format", "csv", "--out", str(run)], capsys)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]
    from ipf_jax.cli import main

    assert "--format csv but the file is named .trc" in _one_error(  # wrote CSV text into x.trc
        ["export", str(run), "--format", "csv", "--out", str(tmp_path / "x.trc")], capsys)
    assert main(["export", str(run), "--format", "csv", "--out", str(run / "export.csv")]) == 0
    from ipf_jax.data.runfiles import write_rows
    from ipf_jax.errors import IPFError

    with pytest.raises(IPFError, match="cannot write"):  # the writer itself leaves no FILE.tmp either
        write_rows(run, ["frame", "time_s", "a"], [0], [0.0], [[1.0]])
    assert not (tmp_path / "run.tmp").exists()


def test_usage_errors_are_one_line_too(capsys):
    import pytest

    from ipf_jax.cli import main

    for argv, problem in ((["track", "x", "--out", "o", "--frames", "abc"], "--frames must be"),
                          (["track", "x"], "the following arguments are required: --out"),
                          (["gait", "x.trc", "--out", "o", "--method", "magic"], "invalid choice: 'magic'")):
        with pytest.raises(SystemExit) as e:
            main(argv)
        err = [x for x in capsys.readouterr().err.splitlines() if x.strip()]
        assert e.value.code == 2 and len(err) == 1 and err[0].startswith("error: ipf-jax ") and problem in err[0], err


def test_floor_range_max_error_and_joint_lists_are_checked(tmp_path, capsys):
    assert "within -0.5..2 m of the floor" in _one_error(
        ["track", str(tmp_path), "--out", str(tmp_path / "r"), "--floor-range=5,6"], capsys)
    assert "--max-error must be a positive number" in _one_error(
        ["calibrate", "--board", "9x6", "--square", "0.025", "--camera", "a=x*.jpg", "--max-error", "-1",
         "--out", str(tmp_path / "c.json")], capsys)
    assert "--joints ',' names no joint" in _one_error(
        ["eval", str(tmp_path / "a.csv"), str(tmp_path / "b.csv"), "--out", str(tmp_path / "e"),
         "--joints", ","], capsys)
