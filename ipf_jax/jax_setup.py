"""Process-wide JAX settings: the persistent compilation cache (compiles once per machine), and
releasing compiled programs before a long-lived process runs out of memory maps.

Every compiled XLA CPU program holds a few memory mappings until JAX's in-memory caches drop it.
A process that compiles many shapes (a sweep run in-process, a test session) can reach the
kernel's per-process limit (Linux ``vm.max_map_count``, 65,530 by default), and the next mapping
fails inside XLA as a segmentation fault, not as a Python error. :func:`release_compiled` clears
JAX's caches once the process has used a given share of that limit; programs needed again come
back from the persistent cache.
"""
from __future__ import annotations

import gc
import os
from pathlib import Path

import jax

from . import lowered
from .paths import cache_dir

_DONE = False
#: Compile time (s) from which a program goes into the persistent cache.
MIN_CACHED_COMPILE_S = 0.05


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
    lowered.enable(cache_dir() / "lowered")  # and the lowerings, which that cache does not keep
    # the raster stages compile in 0.1-0.2 s per window size and load from the cache in about
    # 0.01-0.03 s: kept from 0.05 s on, a run meets a new size at a load, not a compile
    jax.config.update("jax_persistent_cache_min_compile_time_secs", MIN_CACHED_COMPILE_S)
    jax.config.update("jax_persistent_cache_min_entry_size_bytes", 0)


#: Vector extensions XLA's CPU backend compiles for when the host has them, widest first.
_VECTOR_ISAS = ("avx512f", "avx2", "avx", "sse4_2", "asimd", "neon")


def host_cpu() -> dict:
    """``{"model": ..., "vector_isa": ...}``: the CPU and the widest vector extension it reports
    (Linux ``/proc/cpuinfo``; ``platform`` elsewhere, ``vector_isa`` then None).

    XLA compiles the float32 geometry for the host it runs on, so another instruction set can
    round a projected coordinate otherwise, move a count by a pixel and make the same seed's
    tracks part ways (docs/formats.md, Determinism): results name the CPU they ran on."""
    import platform

    model, flags = platform.processor() or platform.machine(), set()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            key, _, value = line.partition(":")
            key = key.strip()
            if key == "model name":
                model = value.strip()
            elif key in ("flags", "Features") and not flags:
                flags = set(value.split())
    except OSError:
        pass
    return {"model": model, "vector_isa": next((f for f in _VECTOR_ISAS if f in flags), None)}


#: Share of the kernel's memory-map limit at which :func:`release_compiled` clears JAX's caches.
MAP_SHARE = 0.5
_PROC_MAPS = Path("/proc/self/maps")
_MAX_MAPS = Path("/proc/sys/vm/max_map_count")


def map_usage() -> tuple[int, int] | None:
    """(memory maps of this process, the kernel's limit), or None where /proc does not tell."""
    try:
        with _PROC_MAPS.open("rb") as f:
            used = sum(1 for _ in f)
        limit = int(_MAX_MAPS.read_text().split()[0])
    except (OSError, ValueError, IndexError):
        return None
    return used, limit


def release_compiled(share: float = MAP_SHARE) -> bool:
    """Clear JAX's in-memory compiled programs when this process uses more than ``share`` of the
    memory-map limit; True when it cleared. A no-op where the limit cannot be read."""
    usage = map_usage()
    if usage is None or usage[0] <= share * usage[1]:
        return False
    jax.clear_caches()
    gc.unfreeze()  # a frozen cycle (``gc.freeze``, as ``ipf-jax track`` does) is never collected
    gc.collect()
    return True
