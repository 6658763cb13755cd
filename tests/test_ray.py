"""The Ray backend on a real local Ray (2 CPUs): same cells, same seeds -> the same results as local."""
import json

import pytest
from test_sweep import read_summary, write_config, write_scene

from ipf_jax.cli import main

ray = pytest.importorskip("ray", reason="the ray extra is not installed (pip install 'ipf-jax[ray]')")
pytestmark = pytest.mark.ray


@pytest.fixture(scope="module")
def local_ray():
    from ipf_jax.sweep.backends import start_ray

    start_ray(num_cpus=2)  # ray.init(num_cpus=2, include_dashboard=False, ...), retried once
    yield
    ray.shutdown()


def test_ray_and_local_sweeps_give_identical_cells(local_ray, tmp_path):
    scene = write_scene(tmp_path)
    cfg = write_config(scene, '[[filter]]\nname = "ipf"\npoints_per_dof = 2\ntop_m = 2\n'
                              '[[filter]]\nname = "apf"\nparticles = 16\nlayers = 2\n', shared="seed = [0, 1]\n")
    assert main(["sweep", str(cfg), "--out", str(tmp_path / "local"), "--quiet"]) == 0
    assert main(["sweep", str(cfg), "--out", str(tmp_path / "ray"), "--backend", "ray", "--quiet"]) == 0
    local = {p.name: json.loads(p.read_text()) for p in (tmp_path / "local" / "cells").glob("*.json")}
    remote = {p.name: json.loads(p.read_text()) for p in (tmp_path / "ray" / "cells").glob("*.json")}
    assert sorted(local) == sorted(remote) and len(local) == 4
    for name, rec in local.items():
        assert remote[name]["backend"] == "ray" and rec["backend"] == "local"
        assert remote[name]["status"] == rec["status"] == "ok"
        assert remote[name]["result"] == rec["result"]  # includes the SHA-256 of joints.csv
    assert read_summary(tmp_path / "ray" / "summary.csv") == read_summary(tmp_path / "local" / "summary.csv")
    assert ray.is_initialized()  # the backend joined the running Ray and left it running
