"""Kill ``ipf-jax track`` mid-run (SIGKILL, in a subprocess), resume it, and get the same bytes.

The in-process crash test in test_tracker.py raises inside the loop; here the operating system
stops the process wherever it is (possibly inside a row or a checkpoint write), which is what a
power cut or an out-of-memory kill does to an unattended run. Then ``--resume`` must produce
``joints.csv`` and ``poses.csv`` byte-identical to an uninterrupted run with the same seed, and
runs must not depend on the chunk size.
"""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from ipf_jax.body import default_shape
from ipf_jax.cli import main
from ipf_jax.data.runfiles import POSE_COLUMNS
from ipf_jax.viz import synthetic as syn
from ipf_jax.viz.synthetic import write_dataset

SHAPE = default_shape(1.75)
N_FRAMES = 24
KILL_AFTER_ROWS = 7  # checkpoints every 3 frames: at least two are on disk by then
TIMEOUT_S = 600.0  # a cold compile cache on a busy machine, not the expected time


@pytest.fixture(scope="module")
def walk(tmp_path_factory) -> Path:
    cams = syn.ring_cameras(2, width=160, height=120, focal_px=150)
    q = syn.procedural_walk(N_FRAMES, shape=SHAPE)
    root = write_dataset(tmp_path_factory.mktemp("kill") / "walk", cams, syn.render_masks(q, SHAPE, cams))
    (root / "init.csv").write_text(",".join(POSE_COLUMNS[2:]) + "\n"
                                   + ",".join(f"{v:.6f}" for v in q[0]) + "\n")
    return root


def track_argv(walk: Path, out: Path, *extra: str, chunk: int = 128) -> list[str]:
    return ["track", str(walk), "--out", str(out), "--quiet", "--resolution", "160",
            "--chunk", str(chunk), "--top-m", "2", "--points-per-dof", "2", "--height", "1.75",
            "--init-pose", str(walk / "init.csv"), "--init-budget", "small", "--checkpoint-every", "3",
            "--seed", "5", *extra]


def data_rows(path: Path) -> int:
    """Complete rows (newline-terminated) after the header; 0 while the file does not exist."""
    try:
        return max(path.read_bytes().count(b"\n") - 1, 0)
    except FileNotFoundError:
        return 0


def kill_mid_run(argv: list[str], joints: Path, sig: int = signal.SIGKILL) -> tuple[int, str]:
    """Start ``ipf-jax argv`` and send it ``sig`` once ``joints`` has KILL_AFTER_ROWS rows; its
    return code and standard error."""
    proc = subprocess.Popen([sys.executable, "-m", "ipf_jax.cli.main", *argv],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    deadline = time.monotonic() + TIMEOUT_S
    try:
        while data_rows(joints) < KILL_AFTER_ROWS:
            if proc.poll() is not None:
                pytest.fail(f"the run ended before it could be killed: {proc.stderr.read().decode()[-500:]}")
            if time.monotonic() > deadline:
                pytest.fail(f"no {KILL_AFTER_ROWS} rows within {TIMEOUT_S} s")
            time.sleep(0.01)
        os.kill(proc.pid, sig)
        proc.wait(timeout=TIMEOUT_S)
    finally:
        if proc.poll() is None:
            proc.kill()  # SIGKILL as well; also when the test failed before its kill
        proc.wait()
    return proc.returncode, proc.stderr.read().decode()


def test_sigkill_then_resume_is_byte_identical(walk, tmp_path, capsys):
    full, cut = tmp_path / "full", tmp_path / "cut"
    assert main(track_argv(walk, full)) == 0

    assert kill_mid_run(track_argv(walk, cut), cut / "joints.csv")[0] == -signal.SIGKILL
    done = data_rows(cut / "joints.csv")
    assert KILL_AFTER_ROWS <= done < N_FRAMES  # really stopped mid-run
    assert (cut / "checkpoint.npz").exists()

    # resuming with other settings is refused and leaves the files as they are
    before = {p.name: p.read_bytes() for p in cut.iterdir() if p.is_file()}
    capsys.readouterr()
    assert main(track_argv(walk, cut, "--resume", "--speed-scale", "0.8")) == 2
    assert "cannot resume: the run in this folder used other settings or data" in capsys.readouterr().err
    assert {p.name: p.read_bytes() for p in cut.iterdir() if p.is_file()} == before

    assert main(track_argv(walk, cut, "--resume")) == 0
    for name in ("joints.csv", "poses.csv"):
        assert (cut / name).read_bytes() == (full / name).read_bytes(), name
    assert not list(cut.glob("*.tmp"))  # temporaries of an interrupted atomic write are gone
    values = np.genfromtxt(cut / "joints.csv", delimiter=",", skip_header=1)
    assert values.shape[0] == N_FRAMES and np.isfinite(values).all()


def test_chunk_size_does_not_change_the_files(walk, tmp_path):
    for chunk in (128, 64):
        assert main(track_argv(walk, tmp_path / str(chunk), "--frames", "0:8", chunk=chunk)) == 0
    for name in ("joints.csv", "poses.csv"):
        assert (tmp_path / "128" / name).read_bytes() == (tmp_path / "64" / name).read_bytes(), name


def test_sigterm_keeps_every_finished_frame_for_resume(walk, tmp_path):
    """A scheduler's SIGTERM is unwound like Ctrl-C: one line, exit 143, and a checkpoint of the
    frames done (none was due: one every 100 frames), from which --resume finishes the run with
    the bytes of an uninterrupted one."""
    full, cut = tmp_path / "full", tmp_path / "cut"
    every = ("--checkpoint-every", "100")
    assert main(track_argv(walk, full, *every)) == 0
    rc, err = kill_mid_run(track_argv(walk, cut, *every), cut / "joints.csv", signal.SIGTERM)
    assert rc == 128 + signal.SIGTERM
    assert err.strip().splitlines()[-1] == "terminated (rows written so far are kept; rerun with --resume)"
    assert (cut / "checkpoint.npz").exists()
    assert KILL_AFTER_ROWS <= data_rows(cut / "joints.csv") < N_FRAMES
    assert main(track_argv(walk, cut, *every, "--resume")) == 0
    for name in ("joints.csv", "poses.csv"):
        assert (cut / name).read_bytes() == (full / name).read_bytes(), name


def test_a_sigterm_whose_exception_was_lost_still_stops_the_run(walk, tmp_path, monkeypatch, capsys):
    """A signal handler's exception raised inside a ``__del__`` or a C callback is printed and
    dropped by Python; the stop it asked for is recorded, and the frame loop ends the run at the
    next frame like any SIGTERM: exit 143, the frames done kept, resumable to the same bytes."""
    from ipf_jax import stop
    from ipf_jax.tracking.tracker import Tracker

    full, cut = tmp_path / "full", tmp_path / "cut"
    assert main(track_argv(walk, full)) == 0
    real = Tracker.track_frame

    def track_frame(self, state, frame, *args, **kwargs):
        out = real(self, state, frame, *args, **kwargs)
        if frame == 4:
            try:
                stop.request()  # the handler's raise, lost where it landed
            except stop.Terminated:
                pass
        return out

    monkeypatch.setattr(Tracker, "track_frame", track_frame)
    capsys.readouterr()
    assert main(track_argv(walk, cut)) == 128 + signal.SIGTERM
    assert capsys.readouterr().err.strip().splitlines()[-1].startswith("terminated")
    assert data_rows(cut / "joints.csv") == 5  # frames 0-4, the one it was asked during included
    stop.check()  # the command's end cleared it
    monkeypatch.setattr(Tracker, "track_frame", real)
    assert main(track_argv(walk, cut, "--resume")) == 0
    for name in ("joints.csv", "poses.csv"):
        assert (cut / name).read_bytes() == (full / name).read_bytes(), name
