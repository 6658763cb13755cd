"""Every documented command runs: the README's command table and every runnable shell block of
README.md and docs/*.md, on the real data in ``../shared/data``.

Which blocks run: fences tagged ``bash`` are runnable; synopses with placeholders (``DATASET``,
``N``) are tagged ``text``. A fence that mentions ``ipf-jax`` with neither tag fails the test, so a
new block cannot slip past. Each runnable block runs in a fresh working folder laid out like a
checkout (``../shared/data`` resolves; ``docs/`` and ``benchmarks/`` are there), line by line
(``VAR=value`` lines set variables, ``\\`` continues a line, ``taskset -c N`` is dropped: it only
pins timings), and every ``ipf-jax`` command must exit 0, print no traceback and write the files
it promises. ``python -m pip install`` and ``python -m pytest`` lines are not run (CI runs them).

The rule that keeps it small (README, "Documented commands are tested") is :data:`SMALL`: options
appended to each command, overriding the documented ones (argparse keeps the last value).
"""
from __future__ import annotations

import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from ipf_jax.cli import main

REPO = Path(__file__).resolve().parent.parent
DOC_FILES = [REPO / "README.md", *sorted((REPO / "docs").glob("*.md"))]
FIRST_FRAMES = 12  # frames tracked per documented track/batch command (0.6 s at 20 Hz)

#: The documented rule: small settings appended to each command (README, "Documented commands").
SMALL = {
    "track": ["--init-budget", "small", "--shape-frames", "0", "--budget", "648", "--quiet"],
    "compare": ["--init-budget", "small", "--shape-frames", "0", "--budget", "324", "--repeat", "1",
                "--quiet"],
    "batch": ["--init-budget", "small", "--shape-frames", "0", "--budget", "648", "--quiet"],
    "demo": ["--num-frames", "13", "--init-budget", "small", "--shape-frames", "0", "--top-m", "1",
             "--cameras", "2"],
    "bench": ["--quick", "--budget", "2", "--repeats", "1"],
    "render": ["--size", "240", "--quiet"],
}
BUDGET_FLAGS = ("--budget", "--particles", "--top-m")


def fences(path: Path):
    """(line, tag, body) of every fenced block of a markdown file."""
    text = path.read_text()
    for m in re.finditer(r"^```(\w*)\n(.*?)^```", text, re.M | re.S):
        yield text[:m.start()].count("\n") + 1, m.group(1), m.group(2)


def session_block() -> str:
    """The README's "typical session" block (run as one test, in order)."""
    session = (REPO / "README.md").read_text().split("A typical session", 1)[1]
    return re.search(r"```bash\n(.*?)```", session, re.S).group(1)


def runnable_blocks():
    out = []
    for path in DOC_FILES:
        for line, tag, body in fences(path):
            if tag == "bash" and "ipf-jax" in body and body != session_block():
                out.append(pytest.param(path, body, id=f"{path.relative_to(REPO)}:{line}"))
    return out


def test_every_block_that_names_ipf_jax_is_tagged():
    untagged = [f"{p.relative_to(REPO)}:{line}" for p in DOC_FILES for line, tag, body in fences(p)
                if "ipf-jax" in body and tag not in ("bash", "text", "toml", "json", "python")]
    assert not untagged, f"tag these fences bash (runnable) or text (synopsis): {untagged}"


# -- a tiny shell: variables, continuations, comments, '&&' -------------------------------------
def commands_of(block: str) -> list[list[str]]:
    """The block's commands as argument lists, variables expanded (see module doc)."""
    env: dict[str, str] = {}
    lines, cur = [], ""
    for raw in block.splitlines():
        cur += raw.rstrip()
        if cur.endswith("\\"):
            cur = cur[:-1] + " "
            continue
        lines.append(cur)
        cur = ""
    out = []
    for line in lines:
        line = re.sub(r"(^|\s)#.*$", "", line).strip()
        if not line:
            continue
        m = re.fullmatch(r"([A-Za-z_]\w*)=(\S+)", line)
        if m:
            env[m.group(1)] = m.group(2)
            continue
        line = re.sub(r"\$\{?([A-Za-z_]\w*)\}?", lambda v: env.get(v.group(1), v.group(0)), line)
        for part in line.split("&&"):
            argv = shlex.split(part)
            if argv[:2] == ["taskset", "-c"]:
                argv = argv[3:]
            out.append(argv)
    return out


def _flag(argv, name):
    return argv[argv.index(name) + 1] if name in argv else None


def _out_of(argv):
    return Path(_flag(argv, "--out") or _flag(argv, "--json"))


def small(argv: list[str]) -> list[str]:
    """``ipf-jax CMD ...`` with :data:`SMALL` applied (first frames of the dataset for track)."""
    cmd = argv[1]
    extra = list(SMALL.get(cmd, []))
    if cmd in ("track", "compare") and "--frames" not in argv:
        from ipf_jax.data.dataset import open_dataset

        frames = open_dataset(argv[2]).frames[: (2 if cmd == "compare" else FIRST_FRAMES)]
        extra += ["--frames", f"{frames[0]}:{frames[-1] + 1}"]
    if any(f in argv for f in BUDGET_FLAGS) and "--budget" in extra:
        i = extra.index("--budget")
        del extra[i:i + 2]
    return argv[1:] + extra


def promised(argv: list[str]) -> list[Path]:
    """Files a command promises (``argv`` without the program name)."""
    cmd, out = argv[0], _out_of(argv) if ("--out" in argv or "--json" in argv) else None
    if cmd == "demo" and out is None:
        out = Path("ipf-jax-demo")  # demo's default --out
    return {
        "track": lambda: [out / n for n in ("joints.csv", "poses.csv", "run.json")],
        "eval": lambda: [out / "eval.json", out / "per_frame.csv"],
        "gait": lambda: [out / "gait.json", out / "report.html"],
        "compare": lambda: [out / n for n in ("compare.csv", "compare.json", "compare.md")],
        "demo": lambda: [out / "run" / "joints.csv", out / "demo_summary.json"],
        "sweep": lambda: [out / "summary.csv"], "batch": lambda: [out / "summary.csv"],
        "fix-single": lambda: [out / "joints.csv", out / "run.json"],
        "init-dataset": lambda: [out / "dataset.json"],
    }.get(cmd, lambda: [out] if out is not None else [])()


def run_cli(argv: list[str], capfd) -> str:
    """Run one ipf-jax command in-process; assert exit 0, no traceback, promised files."""
    rc = main(argv)
    out, err = capfd.readouterr()
    assert rc == 0, f"ipf-jax {' '.join(argv)} -> exit {rc}\n{err[-2000:]}"
    assert "Traceback" not in out + err, err[-2000:]
    missing = [str(p) for p in promised(argv) if not p.exists()]
    assert not missing, f"ipf-jax {' '.join(argv)} did not write {missing}"
    return out


@pytest.fixture()
def checkout(tmp_path, monkeypatch, shared_data):
    """A working folder laid out like a checkout: ../shared/data, docs/ (a copy), benchmarks/."""
    data = shared_data(".")
    (tmp_path / "shared").symlink_to(data.resolve().parent)
    work = tmp_path / "work"
    work.mkdir()
    shutil.copytree(REPO / "docs", work / "docs")
    (work / "benchmarks").symlink_to(REPO / "benchmarks")
    monkeypatch.chdir(work)
    return work


def run_block(block: str, capfd) -> None:
    for argv in commands_of(block):
        if argv[0] == "ipf-jax":
            run_cli(small(argv), capfd)
        elif argv[:3] in (["python", "-m", "pip"], ["python", "-m", "pytest"]):
            continue  # installation and the test suite itself: what CI runs around this test
        elif argv[0] == "python":
            proc = subprocess.run([sys.executable, *argv[1:]], capture_output=True, text=True)
            assert proc.returncode == 0 and "Traceback" not in proc.stderr, proc.stderr[-2000:]
        else:
            pytest.fail(f"unknown command in a runnable block: {' '.join(argv)}")


@pytest.mark.parametrize("path, block", runnable_blocks())
def test_documented_block_runs(path, block, checkout, capfd):
    run_block(block, capfd)


# -- the README's command table -----------------------------------------------------------------
def table_commands() -> list[str]:
    text = (REPO / "README.md").read_text()
    section = text.split("## Commands", 1)[1].split("\n## ", 1)[0]
    return re.findall(r"^\| `ipf-jax ([a-z-]+)", section, re.M)


WALK = "../shared/data/mocap_walk_render/rajagopal_walk_clean_4cam"
ONE_CAM = "../shared/data/mocap_walk_render/rajagopal_walk_clean_1cam"
SEQ = "../shared/data/parsec_bodytrack/sequenceB_2"
UU = "../shared/data/mocap_walk_render/rajagopal_walk_uu_clean_4cam"
STEREO = "../shared/data/opencv_stereo_calib"


def table_invocations(work: Path) -> dict[str, list[list[str]]]:
    """Concrete arguments for each command of the README table (placeholders filled in)."""
    (work / "cfg.toml").write_text(
        '[sweep]\nframes = "0:3"\n\n[[dataset]]\nname = "walk"\n'
        f'path = "{WALK}"\ntruth = "{WALK}/ground_truth.csv"\n\n'
        '[[filter]]\nname = "sir"\nbudget = [200]\n')
    (work / "manifest.txt").write_text(f"{WALK}, {WALK}/ground_truth.csv\n")
    return {
        "demo": [["demo", "--out", "demo"]],
        "track": [["track", SEQ, "--out", "seq"], ["track", ONE_CAM, "--out", "one"]],
        "score": [["score", SEQ, "--frame", "0", "--poses", "seq/poses.csv", "--out", "score.json",
                   "--backend", "both"]],
        "gait": [["gait", "one/joints.csv", "--out", "gait"]],
        "export": [["export", "seq", "--format", f, "--out", f"seq.{f}"] for f in ("trc", "c3d", "bvh", "csv")],
        "render": [["render", "seq", "--out", "seq.mp4"]],
        "compare": [["compare", SEQ, "--out", "cmp"]],
        "eval": [["eval", "one/joints.csv", f"{ONE_CAM}/ground_truth.csv", "--out", "ev"]],
        "sweep": [["sweep", "cfg.toml", "--out", "sw", "--quiet"]],
        "batch": [["batch", "manifest.txt", "--out", "ba", "--frames", "0:3"]],
        "bench": [["bench", "--json", "bench.json"]],
        "fix-single": [["fix-single", "one", "--out", "one_fixed"]],
        "init-dataset": [["init-dataset", *(f"{UU}/FG{k}" for k in range(1, 5)), "--masks",
                          "--calibration", f"{UU}/CALIB/cameras.json", "--up=-z", "--out", "uu"],
                         ["track", "uu", "--out", "uu_run"]],
        "calibrate": [["calibrate", "--board", "9x6", "--square", "0.025",
                       "--camera", f"left={STEREO}/left*.jpg", "--camera", f"right={STEREO}/right*.jpg",
                       "--out", "stereo_cameras.json"]],
    }


def test_every_command_of_the_readme_table_runs(checkout, capfd):
    invocations = table_invocations(checkout)
    assert sorted(table_commands()) == sorted(invocations), "README table and this test differ"
    for cmd in ("track", "demo", "score", "gait", "export", "render", "compare", "eval", "sweep",
                "batch", "bench", "fix-single", "init-dataset", "calibrate"):  # track first: later
        # commands read its runs
        for argv in invocations[cmd]:
            run_cli(small(["ipf-jax", *argv]), capfd)


def test_the_readme_typical_session_runs_in_order(checkout, capfd):
    block = session_block()
    assert [argv[1] for argv in commands_of(block)] == ["track", "eval", "gait", "render", "export"]
    run_block(block, capfd)


def test_the_readme_library_example_runs_and_imports_the_public_package_only(tmp_path, monkeypatch):
    text = (REPO / "README.md").read_text().split("## Library example", 1)[1]
    code = re.search(r"```python\n(.*?)```", text, re.S).group(1)
    imports = [ln for ln in code.splitlines() if ln.startswith(("import ", "from "))]
    assert imports == ["import ipf_jax as ipf"], imports
    monkeypatch.chdir(tmp_path)
    small = code.replace("procedural_walk(20,", "procedural_walk(3,").replace(
        "ipf.TrackSettings(", "ipf.TrackSettings(init=ipf.InitSettings(headings=8, position_steps=0, "
        "modes=1, keep=8, refine_rounds=1, refine_particles=64, pattern_keep=2, pattern_sweeps=1), "
        "shape_fit=ipf.ShapeFitSettings(frames=0), ")
    assert small != code
    exec(compile(small, "README.md", "exec"), {})
    assert (tmp_path / "out" / "joints.csv").is_file()
