"""Batch reprocessing: one set of tracking settings over many recordings listed in a manifest.

The manifest is a text file, one recording per line: a dataset folder (any layout
:func:`ipf_jax.data.dataset.open_dataset` reads, including a ``dataset.json`` describing videos),
optionally followed by a comma and a truth file in the joints.csv convention. Blank lines and lines
starting with ``#`` are skipped, as is a ``path,truth`` header; relative paths are relative to the
manifest. Quote a path that contains a comma (CSV rules)::

    # recordings of 2024-03
    session01/walk1
    session01/walk2, session01/walk2_vicon.csv

A recording that cannot be read is not a reason to stop the others: it becomes a failed item
with its error, like any item whose tracking fails.
"""
from __future__ import annotations

import csv
from pathlib import Path

from ..body.limits import PRESETS
from ..errors import IPFError, require
from .spec import Cell, check_filter, make_cell, resolve


def settings_from_args(args, base: Path | None = None) -> dict:
    """The spec fields shared by every item, from ``track``-style options (``add_tracking_options``);
    relative file options are relative to ``base`` (default: the working directory)."""
    from ..cli.commands import filter_options

    base = Path.cwd() if base is None else base
    options = filter_options(args)
    if "interesting" in options:
        options["interesting"] = list(options["interesting"])
    track = {"budget": args.budget, "resolution": args.resolution, "fps": args.fps, "height_m": args.height,
             "shape_file": str(resolve(args.shape, base)) if args.shape else None,
             "limits": args.limits if args.limits in PRESETS else str(resolve(args.limits, base)),
             "up_axis": args.up, "seed": args.seed, "chunk": args.chunk, "kernel": args.kernel,
             "floor_range": None if args.floor_range is None else list(args.floor_range)}
    frames = None
    if args.frames is not None:
        sl = args.frames
        frames = ":".join("" if v is None else str(v) for v in (sl.start, sl.stop, sl.step))
    init_pose = None
    if args.init_pose:
        init_pose = resolve(args.init_pose, base)
        require(init_pose.suffix.lower() == ".csv", "batch takes --init-pose as a poses.csv-convention "
                "file (a bodytrack InitialPose.txt belongs to one recording)", init_pose)
        require(init_pose.is_file(), "initial pose file not found", init_pose)
        init_pose = str(init_pose)
    return {"filter": args.filter, "options": options, "frames": frames, "init_pose": init_pose,
            "track": {k: v for k, v in track.items() if v is not None},
            "eval": {"joints": None, "align": "none"}}


def read_manifest(path: str | Path) -> list[tuple[Path, Path | None]]:
    """(dataset folder, truth file or None) per manifest line (see module doc)."""
    path = Path(path)
    try:
        lines = path.read_text().splitlines()
    except FileNotFoundError:
        raise IPFError("manifest not found", path) from None
    except (OSError, UnicodeDecodeError) as e:
        raise IPFError(f"not a readable text manifest ({e})", path) from None
    base = path.resolve().parent
    items = []
    for no, row in enumerate(csv.reader(lines), start=1):
        row = [c.strip() for c in row]
        if not row or not row[0] or row[0].startswith("#") or (no == 1 and row[0].lower() == "path"):
            continue
        require(len(row) <= 2 or not any(row[2:]), f"line {no}: expected 'folder' or 'folder, truth.csv' "
                f"(got {len(row)} fields)", path)
        truth = row[1] if len(row) > 1 and row[1] else None
        items.append((resolve(row[0], base), resolve(truth, base) if truth else None))
    require(bool(items), "the manifest lists no recording", path)
    return items


def batch_cells(manifest: str | Path, shared: dict) -> list[Cell]:
    """One cell per manifest line with the ``shared`` settings (:func:`settings_from_args`)."""
    check_filter({"dataset": "", "name": "", **shared}, where="tracking options")
    items = read_manifest(manifest)
    names = [folder.name for folder, _ in items]
    cells: dict[str, Cell] = {}
    for (folder, truth), name in zip(items, names):
        if names.count(name) > 1:  # same folder name in two places: keep them apart in the summary
            name = f"{folder.parent.name}_{name}"
        spec = {"dataset": str(folder), "name": name, "truth": None if truth is None else str(truth),
                **shared}
        cell = make_cell(spec)
        cells.setdefault(cell.id, cell)
    return list(cells.values())
