"""Sweeps and batch reprocessing: ``ipf-jax sweep``, ``ipf-jax batch`` (see docs/evaluation.md).

``spec`` (a cell's settings and stable id), ``config`` (sweep TOML -> cells), ``batch`` (manifest
-> cells), ``runner`` (track + evaluate one cell, failures recorded), ``backends`` (local, ray),
``store`` (atomic per-cell records, resume), ``summary`` (summary.csv/json, Pareto plot); the commands are in :mod:`ipf_jax.cli.sweep`.
"""
from .backends import LocalBackend, RayBackend, make_backend
from .batch import batch_cells, read_manifest
from .config import SweepConfig, load_config
from .runner import execute
from .spec import Cell, cell_id
from .store import Store, run_cells
from .summary import plot_pareto, write_status, write_summary

__all__ = ["Cell", "LocalBackend", "RayBackend", "Store", "SweepConfig", "batch_cells", "cell_id",
           "execute", "load_config", "make_backend", "plot_pareto", "read_manifest", "run_cells",
           "write_status", "write_summary"]
