"""The notebooks run green: each is executed top to bottom in a fresh kernel (nbclient).

They are committed without outputs (never stale) and use small settings; ``02_paper_figures``
reads the shared real data (skipped outside CI when it is absent, a failure in CI). The per-cell
timeout only catches a hang; speed is measured by the benchmarks.
"""
from __future__ import annotations

from pathlib import Path

import nbformat
import pytest

nbclient = pytest.importorskip("nbclient")

NOTEBOOKS = Path(__file__).resolve().parent.parent / "notebooks"
CELL_TIMEOUT_S = 600


def execute(name: str, cwd: Path) -> nbformat.NotebookNode:
    book = nbformat.read(NOTEBOOKS / name, as_version=4)
    client = nbclient.NotebookClient(book, timeout=CELL_TIMEOUT_S, kernel_name="python3",
                                     resources={"metadata": {"path": str(cwd)}})
    client.execute()
    return book


def outputs_text(book) -> str:
    return "\n".join(o.get("text", "") for c in book.cells if c.cell_type == "code"
                     for o in c.get("outputs", []))


@pytest.mark.parametrize("name", sorted(p.name for p in NOTEBOOKS.glob("*.ipynb")))
def test_notebooks_are_committed_without_outputs(name):
    book = nbformat.read(NOTEBOOKS / name, as_version=4)
    stale = [i for i, c in enumerate(book.cells) if c.cell_type == "code"
             and (c.get("outputs") or c.get("execution_count"))]
    assert not stale, f"{name}: cells {stale} carry outputs (clear them before committing)"


def test_quickstart(tmp_path):
    text = outputs_text(execute("01_quickstart.ipynb", tmp_path))
    assert "12 limb joints" in text and "evaluations per frame" in text


def test_paper_figures(tmp_path, shared_data):
    shared_data("parsec_bodytrack/sequenceB_2")
    shared_data("mocap_walk_render/rajagopal_walk_clean_4cam")
    text = outputs_text(execute("02_paper_figures.ipynb", tmp_path))
    assert "mean error of the 12 limb joints" in text and "force plates" in text


def test_filters_compare(tmp_path):
    text = outputs_text(execute("03_filters_compare.ipynb", tmp_path))
    for name in ("ipf", "apf", "sir"):
        assert f"\n{name} " in "\n" + text
