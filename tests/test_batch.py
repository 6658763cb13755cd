"""``ipf-jax batch``: manifest reading, one summary of successes and failures, resume."""
import json
import shutil

import pytest
from test_sweep import read_summary, write_scene

from ipf_jax.body import default_shape
from ipf_jax.cli import main
from ipf_jax.errors import IPFError, IPFWarning
from ipf_jax.sweep import backends, read_manifest

# two frames (initialisation from the given pose + one filter step): the batch command has the
# track command's options, which cannot switch re-initialisation off for a tiny filter
TRACK = ["--frames", "0:2", "--init-pose", "pose0.csv", "--height", str(default_shape().height_m),
         "--up", "+z", "--chunk", "64", "--top-m", "2", "--points-per-dof", "2", "--polish", "0",
         "--no-reach", "--quiet"]


@pytest.fixture(scope="module")
def lab(tmp_path_factory):
    root = write_scene(tmp_path_factory.mktemp("lab"), n_frames=2)
    shutil.copytree(root / "walk", root / "walk2")
    shutil.copytree(root / "walk", root / "walk3")
    (root / "manifest.txt").write_text(
        "path,truth\n# March sessions\nwalk, truth.csv\n\n\"walk2\"\nmissing_take\nwalk3, no_truth.csv\n")
    return root


def test_manifest_lines(lab):
    items = read_manifest(lab / "manifest.txt")
    assert items == [(lab / "walk", lab / "truth.csv"), (lab / "walk2", None), (lab / "missing_take", None),
                     (lab / "walk3", lab / "no_truth.csv")]


def test_manifest_repeats(tmp_path):
    """A recording listed twice merged into one run without a word; with two truths, unsaid which."""
    (tmp_path / "m.txt").write_text("walk, truth.csv\n./walk, truth.csv\nother\n")
    with pytest.warns(IPFWarning, match=r"m.txt: line 2 repeats line 1 \(./walk\): tracked once"):
        assert read_manifest(tmp_path / "m.txt") == [(tmp_path / "walk", tmp_path / "truth.csv"),
                                                     (tmp_path / "other", None)]
    (tmp_path / "m.txt").write_text("walk, truth.csv\nother\nwalk\n")
    with pytest.raises(IPFError, match="line 3: walk is also on line 1 with another truth file"):
        read_manifest(tmp_path / "m.txt")


@pytest.mark.parametrize("text, message", [("# nothing\n\n", "lists no recording"),
                                           ("a, b, c\n", "line 1: expected 'folder' or 'folder, truth.csv'"),
                                           ("walk\n\x00\x01bin\n", "line 2: .* holds a NUL character")])
def test_manifest_mistakes(tmp_path, text, message):
    (tmp_path / "m.txt").write_text(text)
    with pytest.raises(IPFError, match=message):
        read_manifest(tmp_path / "m.txt")


def test_batch_records_failures_and_resumes(lab, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(lab)  # --init-pose is relative to the working directory, like track's
    out = tmp_path / "out"
    assert main(["batch", str(lab / "manifest.txt"), "--out", str(out)] + TRACK) == 1
    printed = capsys.readouterr().out
    assert "batch: 4 recordings, 0 already done, 4 run now; 2 succeeded, 2 failed" in printed
    status = json.loads((out / "summary.json").read_text())
    assert (status["kind"], status["succeeded"], status["failed"]) == ("batch", 2, 2)
    why = {f["dataset"]: f["error"]["message"] for f in status["failures"]}
    assert "dataset folder not found" in why[str(lab / "missing_take")]
    assert "truth file not found" in why[str(lab / "walk3")]
    rows = read_summary(out / "summary.csv")
    assert [r["status"] for r in rows] == ["ok", "ok", "failed", "failed"]
    assert 0 < float(rows[0]["mpjpe_m"]) < 0.2 and rows[1]["mpjpe_m"] == ""  # no truth: no error measured
    assert rows[0]["evaluations_per_frame"] == "336" and rows[0]["frames_done"] == "2"
    assert len(list((out / "items").glob("*.json"))) == 4

    calls = []
    original = backends.execute
    monkeypatch.setattr(backends, "execute", lambda spec, d: calls.append(spec["name"]) or original(spec, d))
    assert main(["batch", str(lab / "manifest.txt"), "--out", str(out)] + TRACK) == 1
    assert calls == [] and "4 already done, 0 run now" in capsys.readouterr().out


def test_batch_option_mistakes_are_one_line(lab, tmp_path, capsys):
    manifest = str(lab / "manifest.txt")
    assert main(["batch", manifest, "--out", str(tmp_path / "o"), "--layers", "3"]) == 2
    assert "layers do not apply to the fipf filter" in capsys.readouterr().err
    assert main(["batch", str(lab / "nope.txt"), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert err == f"error: {lab / 'nope.txt'}: manifest not found"
