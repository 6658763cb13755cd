"""ipf-jax: markerless 3D motion capture and gait analysis by Interval Particle Filtering.

The pipeline is a stack of stage packages (docs/architecture.md), each importing only the ones
below it: ``body`` (topology, shape, limits) -> ``geometry`` (cameras, kinematics, projection, rays)
-> ``likelihood`` (raster, scorer: w = Nc / (Ns + Nm)) | ``filters`` (ipf, fipf, apf, sir) | ``data``
(calibration, datasets, silhouettes, run files) -> ``tracking`` (initialisation, body origin, the
tracker) -> ``analysis`` (gait, evaluation, export, bodytrack, single camera) | ``viz`` (overlays,
synthetic data) -> ``sweep`` -> ``cli``. ``reference`` is the NumPy oracle of the tests.

The public API is re-exported here; names load on first use, so ``import ipf_jax`` stays cheap
(no JAX until a name that needs it is touched)::

    import ipf_jax as ipf
    run = ipf.track(ipf.open_dataset("walk"), "out", ipf.TrackSettings())
"""
from __future__ import annotations

import importlib

__version__ = "0.2.0"

#: public name -> module that defines it
_API = {
    # datasets and run files
    "open_dataset": "ipf_jax.data.dataset", "Dataset": "ipf_jax.data.dataset",
    "MemoryDataset": "ipf_jax.data.dataset", "read_calibration": "ipf_jax.data.calibration",
    "read_run": "ipf_jax.data.rundir", "write_run_dir": "ipf_jax.data.rundir",
    "read_joints_csv": "ipf_jax.data.runfiles", "read_pose_rows": "ipf_jax.data.runfiles",
    # body and geometry
    "BodyShape": "ipf_jax.body.shape", "default_shape": "ipf_jax.body.shape",
    "load_shape": "ipf_jax.body.shape", "load_limits": "ipf_jax.body.limits",
    "Camera": "ipf_jax.geometry.camera", "forward_kinematics": "ipf_jax.geometry.host",
    "up_rotation": "ipf_jax.geometry.world",
    # likelihood and filters
    "Scorer": "ipf_jax.likelihood.scorer", "make_observation": "ipf_jax.likelihood.scorer",
    "weights_from_counts": "ipf_jax.likelihood.scorer", "scoring_cameras": "ipf_jax.likelihood.scorer",
    "make_filter": "ipf_jax.filters.registry",
    # tracking
    "track": "ipf_jax.tracking.passes", "TrackSettings": "ipf_jax.tracking.tracker",
    "RunResult": "ipf_jax.tracking.tracker", "InitSettings": "ipf_jax.tracking.initialise",
    "ShapeFitSettings": "ipf_jax.tracking.shape_fit",
    # analysis and output
    "evaluate_files": "ipf_jax.analysis.evaluation", "analyse_gait": "ipf_jax.analysis.gait",
    "render_run": "ipf_jax.viz.render",
    # modules
    "synthetic": "ipf_jax.viz.synthetic", "profiling": "ipf_jax.profiling",
}
_RENAMED = {"make_filter": "make", "analyse_gait": "analyse"}

__all__ = ["__version__", *sorted(_API)]


def __getattr__(name: str):
    if name not in _API:
        raise AttributeError(f"module 'ipf_jax' has no attribute {name!r}")
    module = importlib.import_module(_API[name])
    value = module if module.__name__.endswith("." + name) else getattr(module, _RENAMED.get(name, name))
    globals()[name] = value
    return value


def __dir__():
    return __all__
