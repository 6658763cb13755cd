"""Shared fixtures: the real data folder (skip outside CI when absent, fail in CI), JAX cache."""
from __future__ import annotations

import os
from pathlib import Path

import pytest

from ipf_jax import jax_setup
from ipf_jax.paths import shared_data_dir

jax_setup.configure()


def _data(sub: str) -> Path:
    path = shared_data_dir() / sub
    if not path.exists():
        if os.environ.get("CI", "").lower() == "true":
            pytest.fail(f"shared data missing in CI: {path}")
        pytest.skip(f"shared data not found: {path} (set IPF_JAX_DATA)")
    return path


@pytest.fixture(scope="session")
def shared_data():
    """Callable: shared_data('parsec_bodytrack/sequenceB_2') -> Path (skips/fails when absent)."""
    return _data


@pytest.fixture(scope="session")
def bodytrack_dir():
    return _data("parsec_bodytrack/sequenceB_2")


@pytest.fixture(scope="module", autouse=True)
def _release_compiled_programs():
    """After each test module, drop JAX's compiled programs once the session holds many: the whole
    suite compiles thousands of shapes, and past the kernel's memory-map limit XLA segfaults."""
    yield
    jax_setup.release_compiled()
