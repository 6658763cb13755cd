"""The checkpoint file of a run (``DIR/checkpoint.npz``): JSON metadata and named arrays, written
atomically. What goes in it is the tracker's state (:mod:`ipf_jax.tracking.state`)."""
from __future__ import annotations

import json
import os
import zipfile
from pathlib import Path

import numpy as np

from ..errors import IPFError
from .runfiles import atomic_temp, dumps

NAME = "checkpoint.npz"


def save(out_dir: Path, meta: dict, arrays: dict[str, np.ndarray]) -> None:
    """Write ``meta`` (JSON-able; :class:`~ipf_jax.data.runfiles.EncodedList` values spliced) and ``arrays`` to ``out_dir/checkpoint.npz`` via a temporary file."""
    out_dir = Path(out_dir)
    payload = {"meta": np.frombuffer(dumps(meta, numpy=False).encode(), np.uint8), **arrays}
    fd, tmp = atomic_temp(out_dir / NAME)
    with os.fdopen(fd, "wb") as fh:
        np.savez(fh, **payload)
        fh.flush()
        os.fsync(fh.fileno())
    os.replace(tmp, out_dir / NAME)


def load(out_dir: Path) -> tuple[dict, dict[str, np.ndarray], Path]:
    """(meta, arrays, path) of ``out_dir``'s checkpoint; IPFError when absent or corrupt."""
    path = Path(out_dir) / NAME
    if not path.exists():
        raise IPFError("no checkpoint to resume from (run without --resume)", path)
    try:
        with np.load(path) as z:
            meta = json.loads(bytes(z["meta"]).decode())
            arrays = {k: z[k] for k in z.files if k != "meta"}
    except (OSError, ValueError, EOFError, KeyError, zipfile.BadZipFile) as e:
        raise IPFError(f"corrupt checkpoint ({e})", path) from None
    if not isinstance(meta, dict):
        raise IPFError("corrupt checkpoint (no metadata)", path)
    return meta, arrays, path


def remove_stale(out_dir: Path) -> None:
    """Delete temporary files a kill during an atomic write left behind."""
    for stale in [*Path(out_dir).glob(f"{NAME}*.tmp"), *Path(out_dir).glob("run.json*.tmp")]:
        stale.unlink(missing_ok=True)
