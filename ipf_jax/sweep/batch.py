"""Batch reprocessing: one set of tracking settings over many recordings listed in a manifest.

The manifest is a text file, one recording per line: a dataset folder (any layout
:func:`ipf_jax.data.dataset.open_dataset` reads, including a ``dataset.json`` describing videos),
optionally followed by a comma and a truth file in the joints.csv convention. Blank lines and lines
starting with ``#`` are skipped, as is a ``path,truth`` header; relative paths are relative to the
manifest. A recording listed twice is tracked once (a warning names the line); twice with
different truth files, an error. Quote a path that contains a comma (CSV rules)::

    # recordings of 2024-03
    session01/walk1
    session01/walk2, session01/walk2_vicon.csv

A recording that cannot be read is not a reason to stop the others: it becomes a failed item
with its error, like any item whose tracking fails.
"""
from __future__ import annotations

import csv
import warnings
from pathlib import Path

from ..errors import IPFError, IPFWarning, require
from .spec import Cell, check_filter, make_cell, resolve


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
    items, seen = [], {}
    for no, row in enumerate(csv.reader(lines), start=1):
        row = [c.strip() for c in row]
        if not row or not row[0] or row[0].startswith("#") or (no == 1 and row[0].lower() == "path"):
            continue
        require(len(row) <= 2 or not any(row[2:]), f"line {no}: expected 'folder' or 'folder, truth.csv' "
                f"(got {len(row)} fields)", path)
        truth = row[1] if len(row) > 1 and row[1] else None
        try:
            item = (resolve(row[0], base), resolve(truth, base) if truth else None)
        except IPFError as e:
            raise IPFError(f"line {no}: {e.message}", path) from None
        key = item[0].resolve()
        if key in seen:  # the same recording twice: once is what was meant, unless the truths differ
            first, truth_then = seen[key]
            require(truth_then == item[1], f"line {no}: {row[0]} is also on line {first} with another "
                    "truth file: which one?", path)
            warnings.warn(IPFWarning(f"{path.name}: line {no} repeats line {first} ({row[0]}): "
                                     "tracked once"))
            continue
        seen[key] = (no, item[1])
        items.append(item)
    require(bool(items), "the manifest lists no recording", path)
    return items


def batch_cells(manifest: str | Path, shared: dict) -> list[Cell]:
    """One cell per manifest line with the ``shared`` settings (:func:`ipf_jax.cli.sweep.settings_from_args`)."""
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
