"""Tracking speed of the working tree against another git revision, measured in one run.

    python benchmarks/vs_revision.py --rev REV | --tree DIR [--cameras 4] [--frames 12] [--repeats 3]
                                     [--data SET] [--json FILE] -- TRACK OPTIONS (e.g. --filter apf)

Both trees track the same frames with the same options through ``python -m ipf_jax.cli track``
(an interface every revision has), alternately (A B A B ...), so drifts of the machine's speed hit
both; each run's seconds per tracked frame come from its ``run.json``. REV is checked out with
``git worktree`` into a temporary folder beside the repository's ``.git`` (removed afterwards)
and run with ``PYTHONPATH`` pointing at it; ``--tree DIR`` uses a checkout that is already there
instead (e.g. an older revision's worktree), left as it is.

The frames: ``sequenceB_2``'s two real frames (4 calibrated cameras, real masks; ``--cameras 1``
keeps Camera1) written ``--frames`` times alternately into a temporary bodytrack-layout folder,
started from bodytrack's ``InitialPose.txt`` (no automatic initialisation). The first run of each
tree compiles (persistent cache) and is not counted. Prints, per repeat and as the median, each
tree's seconds per frame and the ratio REV / working tree (> 1: the working tree is faster), for
the whole run's mean per tracked frame and for its median frame. The two differ by the one-off
costs: a frame that meets a new window size traces (or, with ``ipf_jax.lowered``, reads), lowers
and loads a program (0.1-0.3 s a size before that module, 0.02-0.03 s with it, on a 2-core
machine), a few times in a 40-frame run and rarely once a run has seen its sizes, so the mean is a
short clip's speed and the median a long recording's.

``--data SET`` tracks a data set's first ``--frames`` frames as a user would (automatic
initialisation and, with today's defaults, the shape fit; ``--cameras`` is then the set's), e.g. a
``mocap_walk_render`` set: the seconds are still those of the tracked frames only (``run.json``'s
``per_tracked_frame_mean``, the initialisation frame excluded), which then carry whatever the
one-off searches left behind (e.g. window sizes).
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
DATA = "parsec_bodytrack/sequenceB_2"


def shared_data() -> Path:
    env = os.environ.get("IPF_JAX_DATA")
    return Path(env) if env else (REPO.parent / "shared" / "data").resolve()


def make_dataset(root: Path, cameras: int, frames: int) -> Path:
    """A bodytrack-layout folder with sequenceB_2's frames 0, 1, 0, 1, ... (``frames`` of them)."""
    src = shared_data() / DATA
    (root / "CALIB").mkdir(parents=True)
    for k in range(1, cameras + 1):
        shutil.copy(src / "CALIB" / f"Camera{k}.cal", root / "CALIB" / f"Camera{k}.cal")
        (root / f"FG{k}").mkdir()
        for t in range(frames):
            shutil.copy(src / f"FG{k}" / f"image{t % 2:04d}.bmp", root / f"FG{k}" / f"image{t:04d}.bmp")
    for name in ("InitialPose.txt", "BodyShapeParameters.txt"):
        shutil.copy(src / name, root / name)
    return root


def run_track(tree: Path, data: Path, out: Path, extra: list[str],
              frames: int | None = None) -> tuple[float, float]:
    """One track with ``tree``'s ipf_jax: bodytrack's initial pose, or (``frames``) the data set's
    first frames from an automatic initialisation. Returns s per tracked frame: the mean
    (``run.json``) and the median of the tracked frames' own seconds (``per_frame``), which the few
    frames that met a new window size (a program traced, lowered and loaded) do not move."""
    env = dict(os.environ, PYTHONPATH=str(tree))
    start = (["--init-pose", str(data / "InitialPose.txt"), "--up", "+z"] if frames is None
             else ["--frames", f"0:{frames}"])
    cmd = [sys.executable, "-m", "ipf_jax.cli", "track", str(data), "--out", str(out), "--quiet",
           *start, *extra]
    proc = subprocess.run(cmd, env=env, capture_output=True, text=True, cwd=tempfile.gettempdir(),
                          check=False)
    if proc.returncode != 0:
        sys.exit(f"error: {tree}: track failed: {(proc.stderr.strip().splitlines() or ['?'])[-1]}")
    run = json.loads((out / "run.json").read_text())
    own = [f["seconds"] for f in run["per_frame"] if f.get("status") != "init" and "seconds" in f]
    return float(run["seconds"]["per_tracked_frame_mean"]), float(np.median(own))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    which = ap.add_mutually_exclusive_group(required=True)
    which.add_argument("--rev", help="the git revision to compare with (e.g. main)")
    which.add_argument("--tree", help="a checked-out tree to compare with (not checked out again)")
    ap.add_argument("--cameras", type=int, default=4)
    ap.add_argument("--frames", type=int, default=12)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--data", help="track this data set's first --frames frames, initialised "
                    "automatically (default: sequenceB_2 0, 1, 0, ... from bodytrack's pose)")
    ap.add_argument("--json", help="write the measurements here")
    ap.add_argument("track_args", nargs="*", help="options for ipf-jax track (after --)")
    args = ap.parse_args(argv)
    tmp = Path(tempfile.mkdtemp(prefix="ipf-vs-"))
    other = Path(args.tree).resolve() if args.tree else tmp / "rev"
    if args.tree is None:
        subprocess.run(["git", "-C", str(REPO), "worktree", "add", "--detach", str(other), args.rev],
                       check=True, capture_output=True)
    else:
        args.rev = str(other)
        if not (other / "ipf_jax" / "__init__.py").is_file():
            # PYTHONPATH to a folder without the package would silently run the installed one,
            # i.e. this tree against itself
            sys.exit(f"error: {other} holds no ipf_jax package (give a checkout of the repository)")
    try:
        own = Path(args.data).resolve() if args.data else None
        data = own or make_dataset(tmp / "data", args.cameras, args.frames)
        frames = args.frames if own else None
        trees = {"working tree": REPO, args.rev: other}
        for name, tree in trees.items():  # compile (persistent cache), not counted
            run_track(tree, data, tmp / f"warm-{abs(hash(name))}", args.track_args, frames)
        times = {name: [] for name in trees}  # per run: (mean, median frame) s per tracked frame
        for r in range(args.repeats):
            for name, tree in trees.items():
                times[name].append(run_track(tree, data, tmp / f"run{r}-{abs(hash(name))}",
                                             args.track_args, frames))
            (a_mean, a_med), (b_mean, b_med) = times[args.rev][-1], times["working tree"][-1]
            print(f"repeat {r + 1}: " + ", ".join(f"{n} {t[-1][0]:.4f} s/frame (median frame "
                                                  f"{t[-1][1]:.4f})" for n, t in times.items())
                  + f", ratio {a_mean / b_mean:.2f} (median frames {a_med / b_med:.2f})", flush=True)
        ratios = [a[0] / b[0] for a, b in zip(times[args.rev], times["working tree"])]
        steady = [a[1] / b[1] for a, b in zip(times[args.rev], times["working tree"])]
        doc = {"rev": args.rev, "track_args": args.track_args, "data": args.data or DATA,
               "cameras": args.cameras if own is None else None, "frames": args.frames,
               "seconds_per_frame": {n: [t[0] for t in v] for n, v in times.items()},
               "median_frame_seconds": {n: [t[1] for t in v] for n, v in times.items()},
               "ratio_rev_over_working_tree": ratios, "median_ratio": float(np.median(ratios)),
               "ratio_of_median_frames": steady, "median_ratio_of_median_frames": float(np.median(steady))}
        print(f"median: {args.rev} / working tree = {doc['median_ratio']:.2f} (whole runs' mean s per "
              f"tracked frame); {doc['median_ratio_of_median_frames']:.2f} (median frames, which the few "
              "frames that met a new window size do not move)")
        if args.json:
            Path(args.json).write_text(json.dumps(doc, indent=1))
    finally:
        if args.tree is None:
            subprocess.run(["git", "-C", str(REPO), "worktree", "remove", "--force", str(other)],
                           check=False, capture_output=True)
        shutil.rmtree(tmp, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
