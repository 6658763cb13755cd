"""Programs whose lowering is kept on disk (ipf_jax.lowered): same results as a plain jit, written
once, read back by a new program object (as a new process would), never a stale or corrupt file."""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from ipf_jax import lowered


class Pair(NamedTuple):
    a: jnp.ndarray
    b: jnp.ndarray


lowered.register_namedtuple(Pair)


def _kernel(p, scale, n):
    """A small stand-in for a raster stage: a pytree argument, a traced scalar, a static size."""
    x = jnp.cumsum(p.a[:n] * scale, axis=0)
    return Pair(x, p.b.sum(0)), jnp.int32(n)


@pytest.fixture
def cache(tmp_path):
    before = lowered._DIR
    lowered.enable(tmp_path)
    yield tmp_path
    lowered._DIR = before


def _args(rows=6):
    rng = np.random.default_rng(0)
    return Pair(rng.normal(size=(rows, 3)).astype(np.float32),
                rng.integers(0, 9, size=(rows, 2)).astype(np.int32)), np.float32(1.5)


def _same(x, y):
    for u, v in zip(jax.tree.leaves(x), jax.tree.leaves(y)):
        np.testing.assert_array_equal(np.asarray(u), np.asarray(v))
    assert jax.tree.structure(x) == jax.tree.structure(y)


def test_results_equal_a_plain_jit_and_a_new_program_reads_the_file(cache):
    want = jax.jit(_kernel, static_argnames="n")(*_args(), n=4)
    first = lowered.Program(_kernel, ("n",))
    _same(first(*_args(), n=4), want)
    assert (first.exports, first.loads) == (1, 0)
    assert len(list(cache.rglob("*.jaxexport"))) == 1
    second = lowered.Program(_kernel, ("n",))  # a new process meets the same signature
    _same(second(*_args(), n=4), want)
    assert (second.exports, second.loads) == (0, 1)
    second(*_args(), n=5)  # a new static size is a new module
    second(*_args(rows=7), n=4)  # and so is a new shape
    assert second.exports == 2 and len(list(cache.rglob("*.jaxexport"))) == 3
    size = second._cache_size()
    second(*_args(), n=4)  # the jit's own cache dispatches a signature met before
    assert second._cache_size() == size and second.loads + second.exports == 3


def _normal(k):
    return jax.random.normal(k, (4,))


def test_other_jax_settings_are_other_files(cache):
    """A program lowered under other JAX settings (here the PRNG's partitioning) is not read."""
    want_on = jax.jit(_normal)(jax.random.PRNGKey(3))
    draw = lowered.Program(_normal)
    np.testing.assert_array_equal(np.asarray(draw(jax.random.PRNGKey(3))), np.asarray(want_on))
    assert draw.exports == 1
    flag = jax.config.jax_threefry_partitionable
    try:
        jax.config.update("jax_threefry_partitionable", not flag)
        want_off = jax.jit(lambda k: jax.random.normal(k, (4,)))(jax.random.PRNGKey(3))
        again = lowered.Program(_normal)
        np.testing.assert_array_equal(np.asarray(again(jax.random.PRNGKey(3))), np.asarray(want_off))
        assert again.exports == 1 and len(list(cache.rglob("*.jaxexport"))) == 2
    finally:
        jax.config.update("jax_threefry_partitionable", flag)


def test_a_corrupt_file_is_exported_again(cache):
    lowered.Program(_kernel, ("n",))(*_args(), n=4)
    (path,) = cache.rglob("*.jaxexport")
    path.write_bytes(b"not a module")
    again = lowered.Program(_kernel, ("n",))
    _same(again(*_args(), n=4), jax.jit(_kernel, static_argnames="n")(*_args(), n=4))
    assert again.exports == 1 and path.read_bytes() != b"not a module"


def test_old_versions_folders_are_pruned_before_the_first_write(cache, monkeypatch):
    import time

    old, recent, other = cache / ("0" * 16), cache / ("1" * 16), cache / "notes"
    for d in (old, recent, other):
        d.mkdir()
        (d / "a.jaxexport").write_bytes(b"")
    past = time.time() - (lowered.PRUNE_DAYS + 1) * 86400
    for d in (old, other):
        os.utime(d, (past, past))
    monkeypatch.setattr(lowered, "_PRUNED", False)
    lowered.Program(_kernel, ("n",))(*_args(), n=3)
    assert not old.exists() and recent.exists() and other.exists()  # only old versions' folders
    assert len(list((cache / lowered._SOURCE[:16]).glob("*.jaxexport"))) == 1


def test_the_source_version_does_not_depend_on_where_the_checkout_is(tmp_path):
    """Another checkout of the same sources reads the same files (a hash of relative paths)."""
    pkg = Path(lowered.__file__).parent
    copy = tmp_path / "elsewhere"
    shutil.copytree(pkg, copy / "ipf_jax", ignore=shutil.ignore_patterns("__pycache__"))
    code = "import ipf_jax.lowered as m; print(m._SOURCE)"
    out = subprocess.run([sys.executable, "-c", code], cwd=copy, capture_output=True, text=True,
                         env={**os.environ, "PYTHONPATH": str(copy)}, check=True)
    assert out.stdout.strip() == lowered._SOURCE


def _closure(scale):
    def f(x):
        return x * scale
    return f


def test_closures_lambdas_and_python_scalars_are_plain_jits(cache):
    """No file for what its name cannot tell apart: closures' values, lambdas, weak types."""
    two, three = lowered.Program(_closure(2.0)), lowered.Program(_closure(3.0))
    x = np.ones(3, np.float32)
    np.testing.assert_array_equal(np.asarray(two(x)), 2 * x)
    np.testing.assert_array_equal(np.asarray(three(x)), 3 * x)
    plus = lowered.Program(lambda v: v + 1)
    np.testing.assert_array_equal(np.asarray(plus(x)), x + 1)
    scalar = lowered.Program(_kernel, ("n",))
    out, _ = scalar(_args()[0], 1.5, n=4)  # a Python float: weak-typed, traced as the plain jit
    assert out.a.dtype == np.float32
    assert two.exports + three.exports + plus.exports + scalar.exports == 0
    assert not list(cache.rglob("*.jaxexport"))


def test_off_without_a_folder_and_for_what_cannot_be_exported(cache):
    lowered.disable()
    plain = lowered.Program(_kernel, ("n",))
    plain(*_args(), n=4)
    assert plain.exports == 0 and not list(cache.rglob("*"))
    lowered.enable(cache)

    def host(x):  # a host callback has no stable serialisation: traced as a plain jit instead
        return jax.pure_callback(lambda v: np.asarray(v) * 2, jax.ShapeDtypeStruct(x.shape, x.dtype), x)

    prog = lowered.Program(host)
    np.testing.assert_array_equal(np.asarray(prog(np.arange(3, dtype=np.float32))), [0, 2, 4])
    assert prog.exports == 0 and not list(cache.rglob("*.jaxexport"))


def test_the_scorer_counts_the_same_through_the_cache(cache):
    """The raster stages through exported modules count exactly what the plain programs count."""
    from ipf_jax.body import default_shape
    from ipf_jax.geometry.world import up_rotation
    from ipf_jax.likelihood import scorer as S
    from ipf_jax.viz import synthetic as syn

    cams = syn.ring_cameras(2, width=96, height=72, focal_px=90)
    shape = default_shape(1.75)
    q = syn.procedural_walk(3, shape=shape)
    masks = syn.render_masks(q, shape, cams)
    particles = q[1] + np.random.default_rng(2).normal(0, 0.02, (24, q.shape[1]))
    obs = S.make_observation(list(masks[1]))
    up = up_rotation("+z")
    stages = (S._geometry_calls_jit, S._counts_jit)
    jax.clear_caches()  # whatever ran before: this process traces the stages again
    exported = [p.exports for p in stages]
    via_disk = S.Scorer(cams, shape, up, chunk=16).counts(particles, obs)
    dense = S.Scorer(cams, shape, up, chunk=16, kernel="dense").counts(particles, obs)
    assert all(p.exports > e for p, e in zip(stages, exported))
    jax.clear_caches()  # as a new process would: the files are read, nothing is exported
    exported, loaded = [p.exports for p in stages], [p.loads for p in stages]
    again = S.Scorer(cams, shape, up, chunk=16).counts(particles, obs)
    again_dense = S.Scorer(cams, shape, up, chunk=16, kernel="dense").counts(particles, obs)
    assert [p.exports for p in stages] == exported
    assert all(p.loads > n for p, n in zip(stages, loaded))
    lowered.disable()
    plain = S.Scorer(cams, shape, up, chunk=16).counts(particles, obs)
    for got in (via_disk, dense, again, again_dense):
        np.testing.assert_array_equal(got, plain)
