"""``ipf-jax sweep CONFIG.toml --out DIR`` and ``ipf-jax batch MANIFEST --out DIR``.

Thin over :mod:`.config` / :mod:`.batch` (what to run), :mod:`.backends` (where), :mod:`.store`
(resume: finished cells are skipped) and :mod:`.summary` (summary.csv, summary.json, pareto.png).
Exit status: 0 when every cell succeeded, 1 when some failed (recorded, the others ran), 2 for a
user mistake in the command or the config (one ``error:`` line, nothing run).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ..data.frames import describe
from ..errors import require
from ..filters import registry
from ..sweep.backends import BACKENDS
from ..sweep.spec import resolve
from ..tracking.options import resolve_path, split
from .options import add_common, values_from_args


def _common(p: argparse.ArgumentParser) -> None:
    add_common(p, "out", help="output folder; rerun with the same folder to resume")
    add_common(p, "backend", choices=BACKENDS, default="local",
               help="local (default: in this process) or ray (one task per cell; pip install 'ipf-jax[ray]')")
    p.add_argument("--address", help="Ray: address of an existing cluster (default: start a local Ray)")
    p.add_argument("--num-cpus", type=int, help="Ray: CPUs of the local Ray it starts (default: all)")
    p.add_argument("--retry-failed", action="store_true", help="rerun cells whose record says failed")
    p.add_argument("--dry-run", action="store_true", help="list the cells and what is done, run nothing")
    add_common(p, "quiet")


def add_parser(subparsers) -> None:
    """Register ``sweep`` and ``batch`` on the main CLI's sub-parsers (both set ``func``)."""
    from .options import add_tracking_options

    p = subparsers.add_parser(
        "sweep", help="accuracy vs cost over a grid of settings (resumable; local or Ray)",
        description="Run every combination of the settings listed in CONFIG.toml on its datasets, "
                    "one record per cell in DIR/cells (a rerun skips finished cells), then write "
                    "DIR/summary.csv and DIR/pareto.png. See docs/evaluation.md.")
    p.add_argument("config", metavar="CONFIG.toml", help="the sweep's TOML (docs/evaluation.md)")
    _common(p)
    p.set_defaults(func=run_sweep)

    p = subparsers.add_parser(
        "batch", help="track many recordings with one set of settings (resumable; local or Ray)",
        description="Track every recording listed in MANIFEST (one dataset folder per line, "
                    "optionally ', truth.csv'); failures are recorded and the others go on; "
                    "DIR/summary.csv and summary.json say what succeeded and what failed and why.")
    p.add_argument("manifest", metavar="MANIFEST", help="one dataset folder per line, optionally "
                   "', truth.csv' (docs/evaluation.md)")
    _common(p)
    add_tracking_options(p)
    p.set_defaults(func=run_batch)


def _execute(cells, args, kind: str):
    from ..sweep.backends import make_backend
    from ..sweep.store import Store, run_cells

    store = Store(Path(args.out), "cells" if kind == "sweep" else "items")
    if args.dry_run:
        for c in cells:
            rec = store.load(c.id)
            print(f"{c.id}  {rec['status'] if rec else 'todo':6s}  {c.label}")
        return store, None, None
    backend = make_backend(args.backend, args.address, args.num_cpus)
    try:
        records, ran = run_cells(cells, store, backend, retry_failed=args.retry_failed,
                                 progress=not args.quiet, desc=kind)
    except KeyboardInterrupt:
        kept = sum(store.load(c.id) is not None for c in cells)
        print(f"interrupted: {kept} of {len(cells)} cells are finished and kept in {store.dir}; "
              "run the same command again to resume", file=sys.stderr)
        raise SystemExit(130) from None
    finally:
        backend.close()
    return store, records, ran


def _report(records, ran: int, kind: str, files: list) -> int:
    from ..sweep.summary import code_versions

    failed = [r for r in records if r["status"] == "failed"]
    unit = "cells" if kind == "sweep" else "recordings"
    print(f"{kind}: {len(records)} {unit}, {len(records) - ran} already done, {ran} run now; "
          f"{len(records) - len(failed)} succeeded, {len(failed)} failed")
    for r in failed[:10]:
        print(f"  failed {r['label']}: {r['error']['type']}: {r['error']['message']}")
    if len(failed) > 10:
        print(f"  ... and {len(failed) - 10} more (see summary.json)")
    versions = code_versions(records)
    if len(versions) > 1:
        print(f"warning: the {unit} were computed by {len(versions)} different versions of ipf_jax "
              f"(files changed during or between runs: {versions}); rerun into a new --out for "
              "results that compare", file=sys.stderr)
    print("wrote " + ", ".join(str(f) for f in files if f is not None))
    if failed:  # the exit status's reason where scripts look for it
        first = failed[0]
        print(f"error: {len(failed)} of {len(records)} {unit} failed (first: {first['label']}: "
              f"{first['error']['message']}; all in summary.json)", file=sys.stderr)
    return 1 if failed else 0


def _title(name: str, records: list[dict]) -> str:
    data = ", ".join(dict.fromkeys(r["settings"]["name"] for r in records))
    frames = sorted({r["result"]["frames_done"] for r in records if r.get("result")})
    counts = f"{frames[0]}" if len(frames) == 1 else f"{frames[0]}-{frames[-1]}" if frames else "?"
    return f"{name}: error vs cost ({data}; {counts} frames per cell)"


def run_sweep(args: argparse.Namespace) -> int:
    from ..sweep.config import load_config
    from ..sweep.summary import plot_pareto, write_status, write_summary

    cfg = load_config(args.config)
    store, records, ran = _execute(cfg.cells, args, "sweep")
    if records is None:
        return 0
    files = [write_summary(records, store.root),
             write_status(records, store.root, kind="sweep", extra={"config": str(Path(args.config).resolve())}),
             plot_pareto(records, store.root / "pareto.png", title=_title(Path(args.config).stem, records))]
    return _report(records, ran, "sweep", files)


def run_batch(args: argparse.Namespace) -> int:
    from ..sweep.batch import batch_cells
    from ..sweep.summary import write_status, write_summary

    cells = batch_cells(args.manifest, settings_from_args(args))
    store, records, ran = _execute(cells, args, "batch")
    if records is None:
        return 0
    files = [write_summary(records, store.root),
             write_status(records, store.root, kind="batch", extra={"manifest": str(Path(args.manifest).resolve())})]
    return _report(records, ran, "batch", files)


def settings_from_args(args, base: Path | None = None) -> dict:
    """The spec fields shared by every item, from ``track``-style options (``add_tracking_options``);
    relative file options are relative to ``base`` (default: the working directory)."""
    base = Path.cwd() if base is None else base
    options, track, run = split(values_from_args(args))
    if "interesting" in options:
        options["interesting"] = list(options["interesting"])
    for key in ("shape_file", "limits"):
        if key in track:
            track[key] = resolve_path(track[key], base)
    if "floor_range" in track:
        track["floor_range"] = list(track["floor_range"])
    frames = describe(run["frames"]) if "frames" in run else None
    init_pose = None
    if run.get("init_pose"):
        init_pose = resolve(run["init_pose"], base)
        require(init_pose.suffix.lower() == ".csv", "batch takes --init-pose as a poses.csv-convention "
                "file (a bodytrack InitialPose.txt belongs to one recording)", init_pose)
        require(init_pose.is_file(), "initial pose file not found", init_pose)
        init_pose = str(init_pose)
    return {"filter": track.pop("filter", registry.DEFAULT), "options": options, "frames": frames,
            "init_pose": init_pose, "track": track, "eval": {"joints": None, "align": "none"}}
