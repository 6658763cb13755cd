"""Resumable execution: one atomically written JSON file per finished cell.

Layout of an output folder ``DIR``::

    DIR/<records>/<id>.json   the cell's record (settings, status, result, timing, error, host)
    DIR/runs/<id>/            its joints.csv, poses.csv, run.json, eval.json

A record file is written (temporary file + rename) only after its cell has finished, so a killed
sweep leaves either a complete record or none. A rerun loads the records of the cells it needs,
skips them (failed ones too, unless ``retry_failed``), and runs only the rest: the finished cells
are never recomputed, and the final records equal those of an uninterrupted run.
"""
from __future__ import annotations

import json
import time
from pathlib import Path

from tqdm import tqdm

from ..data.runfiles import check_writable, write_json_atomic
from .spec import Cell


class Store:
    """Cell records in ``root/<records>/<id>.json``."""

    def __init__(self, root: Path, records: str = "cells"):
        self.root = check_writable(Path(root))
        self.dir = self.root / records
        self.dir.mkdir(exist_ok=True)
        for stale in self.dir.glob("*.tmp"):  # a record half-written when a sweep was killed
            stale.unlink(missing_ok=True)
        self.runs = self.root / "runs"
        self.runs.mkdir(exist_ok=True)

    def path(self, cell_id: str) -> Path:
        return self.dir / f"{cell_id}.json"

    def load(self, cell_id: str) -> dict | None:
        """The record of ``cell_id``, or None when absent or unreadable (then it is rerun)."""
        try:
            doc = json.loads(self.path(cell_id).read_text())
        except (OSError, ValueError):
            return None
        return doc if isinstance(doc, dict) and doc.get("status") in ("ok", "failed") else None

    def save(self, cell: Cell, record: dict, backend: str) -> dict:
        doc = {"id": cell.id, "label": cell.label, "settings": cell.spec, **record,
               "backend": backend, "finished_at": time.strftime("%Y-%m-%dT%H:%M:%S%z")}
        write_json_atomic(self.path(cell.id), doc)
        return doc


def run_cells(cells: list[Cell], store: Store, backend, *, retry_failed: bool = False,
              progress: bool = True, desc: str = "sweep") -> tuple[list[dict], int]:
    """Run every cell without a record (see module doc); returns (records in ``cells`` order,
    number of cells run now). A progress bar over cells goes to stderr."""
    done = {}
    for c in cells:
        rec = store.load(c.id)
        if rec is not None and (rec["status"] == "ok" or not retry_failed):
            done[c.id] = rec
    todo = [c for c in cells if c.id not in done]
    failed = sum(r["status"] == "failed" for r in done.values())
    bar = tqdm(total=len(cells), initial=len(done), desc=desc, unit="cell", disable=not progress)
    try:
        for cell, record in backend.run(todo, store.runs):
            done[cell.id] = store.save(cell, record, backend.name)
            failed += record["status"] == "failed"
            bar.set_postfix(failed=failed, last=cell.label[:40])
            bar.update(1)
    finally:
        bar.close()
    return [done[c.id] for c in cells], len(todo)
