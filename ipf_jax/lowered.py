"""Compiled programs whose lowering is kept on disk: a new process loads a program it has met
before instead of tracing and lowering it again.

JAX's persistent compilation cache (:mod:`ipf_jax.jax_setup`) keeps compiled executables across
processes, but every process still traces and lowers each program it meets before it can look the
executable up. For the raster stages that is 0.03-0.1 s per program, and a tracker meets a new one
whenever a window size changes (a few times in a 40-frame run: docs/benchmarks.md). A
:class:`Program` saves each lowering it makes as a serialised :mod:`jax.export` module and, in a
later process, reads it back (about 3 ms) and lowers only a call of it (8-16 ms); the executable
then comes from the persistent cache as before. The results are the same program's, bit for bit.

The files live in ``$IPF_JAX_CACHE/lowered/<source>`` (default ``~/.cache/ipf-jax/lowered``), one
folder per version of the package's source files (a hash of their contents and relative paths) and
one file per program and argument signature, named by a hash of the function's module, name and
source file, the JAX version and settings (x64, the PRNG, debug checks, ...), the backend, the
static arguments and the arguments' shapes and dtypes: any edit of the package makes a new folder,
and a process writes only while the package's files are those it imported. Files are small (about
12 kB); folders of other versions untouched for :data:`PRUNE_DAYS` days are deleted, and deleting
the whole folder is always safe. The cache is on once :func:`enable` has been called
(``ipf-jax`` does it with the compilation cache, off with ``IPF_JAX_NO_CACHE``) and only on one
device (an exported module fixes its device count; with several devices the programs are plain
:func:`jax.jit`). A module that cannot be exported or read falls back to :func:`jax.jit` for that
signature.

Arguments that are named tuples must be registered for serialisation
(:func:`jax.export.register_namedtuple_serialization`); :func:`register_namedtuple` does it once.
"""
from __future__ import annotations

import functools
import hashlib
import inspect
import os
import shutil
import tempfile
import time
from pathlib import Path

import jax
from jax import export

_DIR: Path | None = None
_ON_ONE_DEVICE: bool | None = None
_REGISTERED: set = set()
_PRUNED = False
_WRITES = True  # False once a write has failed: an unwritable cache is not tried again
#: Folders of other source versions (one per version) untouched this long are deleted.
PRUNE_DAYS = 30
#: Static arguments of these types (and tuples of them) have a stable, faithful ``repr``; other
#: static values are traced as a plain jit (no file).
_PLAIN_STATIC = (int, float, bool, str, type(None))


def enable(path: Path) -> None:
    """Keep lowered programs in ``path`` (created when the first one is written)."""
    global _DIR
    _DIR = Path(path)


def disable() -> None:
    global _DIR
    _DIR = None


def register_namedtuple(cls) -> None:
    """Let arguments and results of type ``cls`` (a NamedTuple) be serialised (once per type)."""
    register = getattr(export, "register_namedtuple_serialization", None)  # JAX >= 0.4.32
    if cls not in _REGISTERED and register is not None:
        register(cls, serialized_name=f"{cls.__module__}.{cls.__qualname__}")
        _REGISTERED.add(cls)


def _hash_files(root: Path, files) -> str:
    """A hash of files' contents and their paths relative to ``root`` (not where the checkout is)."""
    h = hashlib.sha256()
    for f in sorted(files):
        h.update(str(f.relative_to(root)).encode())
        h.update(f.read_bytes())
    return h.hexdigest()


def source_version(root: Path) -> str:
    """A hash of every Python file under ``root`` (contents and relative paths; "" when there is
    none): the version of a package's sources, wherever its checkout is."""
    files = list(Path(root).rglob("*.py"))
    return _hash_files(Path(root), files) if files else ""


def _package_hash() -> str:
    """This package's :func:`source_version` as it is on disk now ("" for an install without its
    sources: then nothing is kept on disk, as no version could be told from another)."""
    return source_version(Path(__file__).resolve().parent)


def _package_stamp() -> tuple:
    """The package's Python files and their modification times (cheaper than their hash)."""
    root = Path(__file__).resolve().parent
    return tuple(sorted((str(f), f.stat().st_mtime_ns) for f in root.rglob("*.py")))


#: The package's source as this process imported it: a file is named by it, and a file is written
#: only while the files on disk are still those (an edit during a run writes nothing).
_SOURCE = _package_hash()
_STAMP = _package_stamp()


@functools.cache
def _module_hash(module_file: str) -> str:
    """A hash of the file defining a program (for programs outside the package: tests, scripts)."""
    path = Path(module_file)
    return _hash_files(path.parent, [path])


#: JAX settings that cannot change a program's lowering (caches, logging, time-outs)
_NOT_LOWERING = ("cache", "log", "timeout", "dump", "explain", "distributed")


def _config() -> list:
    """The JAX settings in force that may change a lowering (x64, the PRNG's implementation and
    partitioning, debug checks, dtype promotion, ...): a file made under other settings is not read."""
    return sorted((k, repr(v)) for k, v in jax.config.values.items()
                  if not any(w in k for w in _NOT_LOWERING))


def _plain(value) -> bool:
    if isinstance(value, tuple):
        return all(_plain(v) for v in value)
    return isinstance(value, _PLAIN_STATIC)


def _prune_once(keep: Path) -> None:
    """Delete the folders of other source versions (named by 16 hex digits, holding only programs)
    untouched for :data:`PRUNE_DAYS` (once per process, before its first write; a read touches its
    folder)."""
    global _PRUNED
    if _PRUNED:
        return
    _PRUNED = True
    old = time.time() - PRUNE_DAYS * 86400
    for d in keep.parent.glob("*"):
        if (d != keep and d.is_dir() and len(d.name) == 16 and all(c in "0123456789abcdef" for c in d.name)
                and d.stat().st_mtime < old and all(f.suffix in (".jaxexport", ".tmp") for f in d.iterdir())):
            shutil.rmtree(d, ignore_errors=True)


def _active() -> bool:
    global _ON_ONE_DEVICE
    if _DIR is None or not _SOURCE:
        return False
    if _ON_ONE_DEVICE is None:
        _ON_ONE_DEVICE = jax.local_device_count() == 1
    return _ON_ONE_DEVICE


class Program:
    """``jax.jit(fn, static_argnames=static, compiler_options=options, donate_argnums=donate)``
    whose lowerings are kept on disk (module doc). Called like that jit: array arguments (pytrees
    of arrays) by position, then the static ones (``fn``'s last parameters) by position or
    keyword; the donated arguments' buffers are the program's to reuse (a donated array is
    deleted by the call, also through the exported module: its call is traced into the jit).

    It is itself a jit (dispatch at the speed of JAX's own cache) of a function that runs only
    when that jit traces a new signature: it reads the signature's exported module, or exports
    and writes it, and calls it, so the trace is a call of an already lowered module.

    Only module-level functions without closures use the disk (a file is named by the function's
    module, name and source file, not by the values a closure holds); others, signatures with a
    weak-typed argument (a Python scalar: its exported type would not be weak), and static
    values other than numbers, strings, None and tuples of them are traced as the plain jit.
    Under :func:`jax.vmap` use the plain jit (``call_exported`` has no batching rule); inside another
    program call ``fn``, the function itself, so it is traced into that program."""

    def __init__(self, fn, static_argnames: tuple[str, ...] = (), compiler_options: dict | None = None,
                 donate_argnums: tuple[int, ...] = ()):
        self.fn = fn
        self.static_argnames = tuple(static_argnames)
        self.compiler_options = dict(compiler_options or {})
        opts = self.compiler_options or None
        donate = tuple(donate_argnums)
        self._jit = jax.jit(fn, static_argnames=self.static_argnames, compiler_options=opts,
                            donate_argnums=donate)

        def traced(*args, **static):  # a function of its own: a jit cache per program
            return self._traced(*args, **static)

        functools.update_wrapper(traced, fn)
        self._via_disk = jax.jit(traced, static_argnames=self.static_argnames,
                                 compiler_options=opts, donate_argnums=donate)
        self._params = list(inspect.signature(fn).parameters)
        self._first_static = min([self._params.index(n) for n in self.static_argnames] or [len(self._params)])
        if not set(self._params[self._first_static:]) <= set(self.static_argnames):
            raise ValueError(f"{getattr(fn, '__name__', fn)}: static arguments must come last")
        qualname = getattr(fn, "__qualname__", "<")
        source = inspect.getsourcefile(fn) if inspect.isfunction(fn) else None
        self._disk = (inspect.isfunction(fn) and fn.__closure__ is None and "<" not in qualname
                      and source is not None)
        self._source_file = source
        self.exports = 0  # modules exported by this process
        self.loads = 0  # modules read from disk by this process

    def __call__(self, *args, **static):
        if len(args) > self._first_static:  # static arguments given by position: by name
            params = self._params
            for i in range(min(len(args), len(params)) - 1, self._first_static - 1, -1):
                if params[i] in self.static_argnames:
                    if params[i] in static:
                        name = getattr(self.fn, "__name__", "program")
                        raise TypeError(f"{name}() got multiple values for argument {params[i]!r}")
                    static[params[i]] = args[i]
                    args = args[:i] + args[i + 1:]
        return (self._via_disk if self._disk and _active() else self._jit)(*args, **static)

    def _cache_size(self) -> int:
        """Signatures traced in this process (for tests that count retraces)."""
        return self._jit._cache_size() + self._via_disk._cache_size()

    def _traced(self, *args, **static):
        leaves = jax.tree.leaves(args)
        exp = None
        if _plain(tuple(static.values())) and not any(getattr(getattr(x, "aval", None), "weak_type", False)
                                                      for x in leaves):
            specs = jax.tree.map(lambda x: jax.ShapeDtypeStruct(x.shape, x.dtype), args)
            exp = self._exported(specs, static)
        return self.fn(*args, **static) if exp is None else exp.call(*args)

    def _file(self, specs, static) -> Path:
        leaves, tree = jax.tree.flatten(specs)
        key = repr((self.fn.__module__, self.fn.__qualname__, _module_hash(self._source_file),
                    jax.__version__, _config(), jax.default_backend(), str(tree),
                    [(x.shape, str(x.dtype)) for x in leaves], sorted(static.items()),
                    sorted(self.compiler_options.items())))
        name = f"{self.fn.__name__}-{hashlib.sha256(key.encode()).hexdigest()[:24]}.jaxexport"
        return _DIR / _SOURCE[:16] / name

    def _exported(self, specs, static):
        """One signature's exported module: read from its file, or exported now (and written);
        None when it cannot be exported (the caller traces ``fn`` itself)."""
        path = self._file(specs, static)
        try:
            exp = export.deserialize(bytearray(path.read_bytes()))
            self.loads += 1
            os.utime(path.parent)  # in use: not pruned
            return exp
        except Exception:  # noqa: BLE001, S110 - missing, corrupt or foreign: export it (again)
            pass
        try:
            exp = export.export(jax.jit(functools.partial(self.fn, **static)))(*specs)
        except Exception:  # noqa: BLE001 - not exportable: traced as a plain jit
            return None
        self.exports += 1
        _write(path, exp)
        return exp


def _write(path: Path, exp) -> None:
    """Save a module, unless the package's source changed since import, a write failed before,
    or it cannot be serialised (then it is only used in this process)."""
    global _WRITES
    if not _WRITES or _package_stamp() != _STAMP:
        return
    try:
        blob = exp.serialize()
    except Exception:  # noqa: BLE001 - e.g. flatbuffers missing: kept in memory only
        _WRITES = False
        return
    try:
        _prune_once(path.parent)
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, suffix=".tmp")
        with os.fdopen(fd, "wb") as f:
            f.write(blob)
        os.replace(tmp, path)
    except OSError:
        _WRITES = False  # an unwritable cache only costs the lowering next time
