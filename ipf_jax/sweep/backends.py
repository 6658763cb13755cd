"""Where cells run: ``local`` (in this process, one after another) or ``ray`` (one task per cell).

Both expose ``run(cells, runs_dir)`` yielding ``(cell, record)`` as cells finish (any order) and
``close()``. Records are written by the caller, in the driver process, so a cell counts as done only
once its file exists, whichever machine ran it.

Ray: ``address=None`` starts a private local Ray (shut down by ``close``); an address joins an
existing cluster (``ray start --head`` ...). Each task asks for one CPU. Workers write the cell's
run folder (joints.csv, ...) into ``runs_dir`` and read the datasets by path, so on a multi-node
cluster both must be on storage every node sees at the same path. Workers inherit the JAX compile
cache settings (``IPF_JAX_CACHE``...) of the driver's environment.
"""
from __future__ import annotations

import os
from pathlib import Path

from ..errors import IPFError, require
from .runner import execute

BACKENDS = ("local", "ray")
#: Environment passed to Ray workers: cache and data locations, JAX platform choice.
WORKER_ENV = ("IPF_JAX_CACHE", "IPF_JAX_NO_CACHE", "IPF_JAX_DATA", "JAX_PLATFORMS", "XLA_FLAGS")


class LocalBackend:
    """In-process, sequential: the embedded default (no server, nothing to install)."""

    name = "local"

    def run(self, cells, runs_dir: Path):
        for cell in cells:
            yield cell, execute(cell.spec, Path(runs_dir) / cell.id)

    def close(self) -> None:
        pass


def _execute_on_worker(spec: dict, work_dir: str) -> dict:
    from .. import jax_setup

    jax_setup.configure()  # the same persistent compile cache as the driver
    return execute(spec, work_dir)


def ray_init_args(address: str | None = None, num_cpus: int | None = None) -> dict:
    """Keyword arguments for ``ray.init``: quiet, no dashboard, workers see our environment."""
    env = {k: os.environ[k] for k in WORKER_ENV if k in os.environ}
    args = {"address": address, "include_dashboard": False, "log_to_driver": False,
            "runtime_env": {"env_vars": env} if env else None}
    if address is None and num_cpus is not None:
        args["num_cpus"] = num_cpus
    return args


def start_ray(address: str | None = None, num_cpus: int | None = None, *, attempts: int = 2) -> None:
    """``ray.init`` with :func:`ray_init_args`, tried again once: on a loaded machine a local Ray
    can miss its own start-up timeouts (the raylet waits a fixed 15 s for its agents)."""
    import ray

    for attempt in range(attempts):
        try:
            ray.init(**ray_init_args(address, num_cpus))
            return
        except Exception as e:  # noqa: BLE001 - Ray raises bare Exception on start-up time-outs
            ray.shutdown()
            if attempt + 1 == attempts or address is not None:
                where = f"the Ray cluster at {address}" if address else "a local Ray"
                raise IPFError(f"cannot start or join {where} ({str(e).splitlines()[0]})") from None


class RayBackend:
    """One Ray task per cell; joins ``address`` or starts a local Ray (see module doc)."""

    name = "ray"

    def __init__(self, address: str | None = None, num_cpus: int | None = None):
        try:
            import ray
        except ModuleNotFoundError:
            raise IPFError("--backend ray needs Ray: pip install 'ipf-jax[ray]'") from None
        self.ray = ray
        self.started = False
        if not ray.is_initialized():
            start_ray(address, num_cpus)
            self.started = True
        self.task = ray.remote(num_cpus=1)(_execute_on_worker)

    def run(self, cells, runs_dir: Path):
        ray = self.ray
        pending = {self.task.remote(c.spec, str(Path(runs_dir).resolve() / c.id)): c for c in cells}
        try:
            while pending:
                ready, _ = ray.wait(list(pending), num_returns=1)
                for ref in ready:
                    cell = pending.pop(ref)
                    try:
                        record = ray.get(ref)
                    except ray.exceptions.RayError as e:  # the worker died (OOM, node lost ...)
                        record = {"status": "failed", "result": None, "timing": None, "host": None,
                                  "error": {"type": type(e).__name__, "message": str(e).splitlines()[0]}}
                    yield cell, record
        finally:
            for ref in pending:  # interrupted: do not leave tasks running on the cluster
                ray.cancel(ref, force=True)

    def close(self) -> None:
        if self.started:
            self.ray.shutdown()
            self.started = False


def make_backend(name: str, address: str | None = None, num_cpus: int | None = None):
    """``local`` or ``ray``; an address or CPU count only makes sense for ``ray``."""
    require(name in BACKENDS, f"unknown backend {name!r} (choose {', '.join(BACKENDS)})")
    require(num_cpus is None or num_cpus >= 1, f"--num-cpus must be >= 1 (got {num_cpus}): a Ray "
            "without CPUs runs no cell and waits for ever")
    if name == "local":
        require(address is None, "--address joins a Ray cluster: use it with --backend ray")
        require(num_cpus is None, "--num-cpus sizes a local Ray: use it with --backend ray")
        return LocalBackend()
    return RayBackend(address, num_cpus)
