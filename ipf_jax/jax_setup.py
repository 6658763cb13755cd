"""Process-wide JAX settings: the persistent compilation cache (compiles once per machine)."""
from __future__ import annotations

import os

import jax

from .paths import cache_dir

_DONE = False


def configure() -> None:
    """Enable the persistent compilation cache (``$IPF_JAX_CACHE``, default ~/.cache/ipf-jax)."""
    global _DONE
    if _DONE:
        return
    _DONE = True
    if os.environ.get("IPF_JAX_NO_CACHE"):
        return
    path = cache_dir() / "jax"
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError:
        return  # an unwritable cache only costs compile time
    jax.config.update("jax_compilation_cache_dir", str(path))
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.5)
    jax.config.update("jax_persistent_cache_min_entry_size_bytes", 0)
