"""Where the shared real data lives: ``$IPF_JAX_DATA`` or ``../shared/data`` beside the checkout."""
from __future__ import annotations

import os
from pathlib import Path

from .errors import IPFError

_REPO = Path(__file__).resolve().parent.parent


def shared_data_dir() -> Path:
    """The folder holding the shared real data sets (may not exist outside CI)."""
    env = os.environ.get("IPF_JAX_DATA")
    if env:
        return Path(env)
    return (_REPO.parent / "shared" / "data").resolve()


def cache_dir() -> Path:
    """Per-user cache (JAX persistent compilation cache), ``$IPF_JAX_CACHE`` overrides."""
    env = os.environ.get("IPF_JAX_CACHE")
    base = Path(env) if env else Path.home() / ".cache" / "ipf-jax"
    return base


def expand_path(value: str, base: Path) -> Path:
    """A path from a config, manifest or option: ``~`` and ``$VARS`` expanded, relative to ``base``."""
    if "\x00" in value:  # no file system takes one (a binary file read as text, a "\u0000" escape)
        raise IPFError(f"{value!r} is not a path: it holds a NUL character")
    p = Path(os.path.expandvars(os.path.expanduser(value)))
    return (p if p.is_absolute() else Path(base) / p).resolve()
