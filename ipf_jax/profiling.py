"""``ipf-jax bench``: throughput of the measure step (JAX and NumPy) and tracking seconds per frame.

The fixed scene is real: PARSEC bodytrack ``sequenceB_2`` frame 0 (its 4 calibrated cameras and
foreground masks, scaled to each scoring resolution; "1 camera" is Camera1) and N poses around the
person: our body fitted to bodytrack's ``InitialPose.txt`` (:func:`ipf_jax.analysis.bodytrack.fit_our_pose`)
plus seeded Gaussian noise of one frame of the filters' default noise rates at 20 Hz, like a
filter's cloud. Every backend scores the same poses (the NumPy ones a prefix of them).

The measure step is the whole likelihood: FK, projection, raster, counts and weights. Backends:

* ``jax-scanline``, ``jax-dense``: :class:`ipf_jax.likelihood.scorer.Scorer` with either kernel;
* ``numpy-scanline``: :mod:`ipf_jax.reference.scanline`, the vectorised NumPy baseline;
* ``numpy-reference``: :mod:`ipf_jax.reference.likelihood`, the NumPy oracle (the model drawn row
  by row in exact integers, :mod:`ipf_jax.likelihood.model_mask`).

Each record times one call on warm code: the first call (compilation, or loading from the
persistent cache) is timed separately as ``compile_s``; then the median of repeats (the scorer
returns host arrays, so every timed call has finished). Peak RSS is the process's high-water mark
over that record alone (reset through ``/proc/self/clear_refs`` where Linux allows it). Tracking
records time frame 1 of ``sequenceB_2`` (frame 0 starts from ``InitialPose.txt``), end to end.

Records are the issue's fields (``backend, height, width, cameras, particles, particles_per_s,
compile_s, peak_rss_mb, device_kind, jax_version``) plus ``task`` ("measure" or "track"),
``seconds``, ``repeats``, ``particles_per_cpu_s`` and the 1-minute ``load_average`` (on a shared
machine other processes take cores: the CPU-time rate is the one they disturb least), and
``machine``. Tracking records add ``filter``, ``seconds_per_frame``, ``cpu_seconds_per_run`` (process CPU
time of the whole two-frame run, all threads: an upper bound of the single-threaded cost of frame 1)
and ``joint_distance_to_peer_m`` (the 12 limb joints against bodytrack's own frame-1 estimate).
Start records (``task`` "start", :func:`bench_start`) time the one-off stages of a default run
(automatic initialisation, shape fit, recoveries) apart from its tracked frames.
"""
from __future__ import annotations

import gc
import os
import platform
import tempfile
import time
from pathlib import Path
from typing import NamedTuple

import numpy as np

from .errors import require

BACKENDS = ("jax-scanline", "jax-dense", "numpy-scanline", "numpy-reference")
DATASET = "parsec_bodytrack/sequenceB_2"
PEER_POSES = "parsec_bodytrack/bodytrack_poses_sequenceB_2_4cams_2frames_4000p_5layers_serial.txt"
NOISE_FPS = 20.0


class Scene(NamedTuple):
    """cameras : C cameras at scoring size;  masks : C (H, W) bool;  particles : (N, D);
    shape : the fitted BodyShape;  up : (3, 3);  init_pose : (D,) the fitted pose."""

    cameras: list
    masks: list
    particles: np.ndarray
    shape: object
    up: np.ndarray
    init_pose: np.ndarray


def initial_pose(data: Path):
    """Our pose and height fitted to bodytrack's InitialPose.txt of ``data``."""
    from .analysis.bodytrack import fit_our_pose, read_body_shape, read_pose
    from .analysis.bodytrack.kinematics import bodytrack_points

    pose = read_pose(data / "InitialPose.txt")[0]
    fit = fit_our_pose(bodytrack_points(pose, read_body_shape(data / "BodyShapeParameters.txt")))
    return fit.q, fit.height_m


def load_scene(data: Path, width: int, n_cameras: int, n: int, *, seed: int = 0) -> Scene:
    """The fixed benchmark scene at a scoring width (height follows the cameras' aspect)."""
    from .body import default_shape
    from .data.dataset import open_dataset
    from .data.silhouette import resize_mask
    from .filters.base import default_noise_rates
    from .geometry.world import up_rotation

    ds = open_dataset(data)
    require(n_cameras <= len(ds.cameras), f"the data set has {len(ds.cameras)} cameras", data)
    cams = [c.scaled(width / c.width) for c in ds.cameras[:n_cameras]]
    masks = [resize_mask(m, c.height, c.width) for m, c in zip(ds.masks(ds.frames[0]), cams)]
    q0, height = initial_pose(data)
    rng = np.random.default_rng(seed)
    particles = q0 + rng.normal(size=(n, len(q0))) * default_noise_rates() / NOISE_FPS
    return Scene(cams, masks, particles, default_shape().scaled_to(height), up_rotation("+z"), q0)


def measure_step(backend: str, scene: Scene, *, chunk: int | None = None, calls=None,
                 threads: int | None = None):
    """The full measure step of a backend: (N, D) particles -> (N,) weights. The JAX scorer's
    chunking is the tracker's for measure calls of ``calls`` particles (default: one call of the
    scene's particles; ``chunk`` given: only the chunks per compiled call are chosen); ``threads``
    its host threads (default: the scorer's)."""
    from .likelihood.scorer import (
        Scorer,
        make_observation,
        pick_chunking,
        weights_from_counts,
    )

    obs = make_observation(scene.masks)
    if backend.startswith("jax-"):
        chunk, block = pick_chunking(calls or [len(scene.particles)], chunk=chunk)
        scorer = Scorer(scene.cameras, scene.shape, scene.up, kernel=backend[4:], chunk=chunk,
                        block=block, threads=threads)

        def step(p):
            return weights_from_counts(scorer.counts(p, obs), obs.active)[0]
        step.chunking = (scorer.chunk, scorer.block)  # as the scorer has it (device rounding)
        step.threads = scorer.threads
        return step
    if backend == "numpy-scanline":
        from .reference import scanline as ref
    else:
        from .reference import likelihood as ref
    return lambda p: weights_from_counts(ref.counts(p, scene.shape.values, scene.up, scene.cameras,
                                                    scene.masks), obs.active)[0]


# -- process facts ---------------------------------------------------------------------------------
def _reset_peak() -> bool:
    gc.collect()
    try:
        Path("/proc/self/clear_refs").write_text("5")  # Linux: VmHWM := VmRSS
        return True
    except OSError:
        return False


def _peak_mb() -> float:
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 1024
    except OSError:
        pass
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def machine() -> dict:
    """The host, as recorded with every result."""
    import jax

    from .jax_setup import host_cpu

    cpu = host_cpu()
    mem = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / 2**30
    return {"cpu": cpu["model"], "vector_isa": cpu["vector_isa"], "cores": os.cpu_count(),
            "memory_gb": round(mem, 1), "os": platform.platform(),
            "python": platform.python_version(), "numpy": np.__version__,
            "jax_devices": len(jax.devices()), "jax_platform": jax.devices()[0].platform,
            "device_kind": jax.devices()[0].device_kind}


def device_line() -> str:
    """What the particles run on, e.g. ``jax 0.10.2 on 1 cpu device (cpu)``: the scorer shards
    the particle axis over every local device of the default backend (CPU, GPU or TPU alike)."""
    import jax

    devs = jax.local_devices()
    kinds = sorted({d.device_kind for d in devs})
    return (f"jax {jax.__version__} on {len(devs)} {devs[0].platform} device"
            f"{'s' if len(devs) > 1 else ''} ({', '.join(kinds)})")


def _load_average() -> float | None:
    """1-minute load average (other processes compete for the cores: recorded with each result)."""
    try:
        return round(os.getloadavg()[0], 2)
    except OSError:
        return None


def _common() -> dict:
    import jax

    return {"device_kind": jax.devices()[0].device_kind, "jax_version": jax.__version__}


# -- the two kinds of record -----------------------------------------------------------------------
def bench_measure(backend: str, scene: Scene, n: int, *, repeats: int = 3,
                  budget_s: float = 60.0, chunk: int | None = None,
                  threads: int | None = None) -> tuple[dict, np.ndarray]:
    """Time the measure step of ``backend`` on the first ``n`` poses -> (record, weights)."""
    exact_peak = _reset_peak()
    particles = scene.particles[:n]
    fn = measure_step(backend, scene, chunk=chunk, calls=[n], threads=threads)
    t0 = time.perf_counter()
    weights = fn(particles)  # compiles (JAX), fixes the window sizes
    first = time.perf_counter() - t0
    times, cpu = [], []
    load = _load_average()
    while len(times) < repeats and (not times or sum(times) < budget_s):
        t0, c0 = time.perf_counter(), time.process_time()
        fn(particles)
        times.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    med = float(np.median(times))
    h, w = scene.masks[0].shape
    rec = {"backend": backend, "height": h, "width": w, "cameras": len(scene.cameras),
           "particles": n, "particles_per_s": round(n / med, 1),
           "chunking": list(getattr(fn, "chunking", ())) or None,
           "threads": getattr(fn, "threads", None),
           "compile_s": round(max(first - med, 0.0), 3) if backend.startswith("jax-") else None,
           "peak_rss_mb": round(_peak_mb(), 1), **_common(),
           "task": "measure", "seconds": round(med, 5), "repeats": len(times),
           "particles_per_cpu_s": round(n / float(np.median(cpu)), 1), "load_average": load,
           "peak_rss_exact": exact_peak}
    return rec, weights


def bench_track(data: Path, filter_name: str, width: int, *, runs: int = 2, seed: int = 0,
                peer: Path | None = None, progress: bool = False) -> dict:
    """Seconds for frame 1 of ``data`` (frame 0 starts from InitialPose.txt), median of the runs
    after the first (which also compiles), and the estimate's joint distance to the peer's."""
    from .data.dataset import open_dataset
    from .tracking.tracker import TrackSettings, track

    exact_peak = _reset_peak()
    ds = open_dataset(data)
    q0, height = initial_pose(data)
    settings = TrackSettings(filter=filter_name, resolution=width, init_pose=q0, height_m=height,
                             seed=seed, checkpoint_every=1000)
    seconds, cpu, res = [], [], None
    load = _load_average()
    for _ in range(runs + 1):
        c0 = time.process_time()
        with tempfile.TemporaryDirectory() as out:
            res = track(ds, out, settings, frames=ds.frames[:2], progress=progress)
        cpu.append(time.process_time() - c0)
        seconds.append(res.run["per_frame"][1]["seconds"])
    med = float(np.median(seconds[1:]))
    evals = int(res.run["per_frame"][1]["evaluations"])
    scoring = res.run["settings"]["scoring_sizes"][0]
    rec = {"backend": "jax-scanline", "height": scoring[1], "width": scoring[0],
           "cameras": len(ds.cameras), "particles": evals,
           "particles_per_s": round(evals / med, 1), "compile_s": round(max(seconds[0] - med, 0.0), 3),
           "peak_rss_mb": round(_peak_mb(), 1), **_common(),
           "task": "track", "filter": filter_name, "seconds_per_frame": round(med, 4),
           "runs": runs, "cpu_seconds_per_run": round(float(np.median(cpu[1:])), 4),
           "load_average": load, "peak_rss_exact": exact_peak}
    if peer is not None and peer.exists():
        from .analysis.bodytrack import mean_joint_distance, peer_joints

        theirs, _ = peer_joints(peer, data / "BodyShapeParameters.txt")
        rec["joint_distance_to_peer_m"] = round(mean_joint_distance(res.joints[1], theirs[1]), 4)
    return rec


def bench_start(data: Path, frames: int = 12, *, seed: int = 0, progress: bool = False) -> dict:
    """The one-off stages of a default run on ``data``'s first ``frames`` frames, apart from its
    tracked frames: the automatic initialisation, the shape fit and any recovery (evaluations and
    seconds each, from ``run.json``), then the tracked frames' mean and median seconds.

    A first run of a dataset in a process: the times include compiling (or loading from the
    persistent cache) the programs of each stage's window sizes, as a user's first run does.
    """
    from .data.dataset import open_dataset
    from .tracking.tracker import TrackSettings, track

    ds = open_dataset(data)
    load = _load_average()
    with tempfile.TemporaryDirectory() as out:
        res = track(ds, out, TrackSettings(seed=seed, checkpoint_every=1000),
                    frames=ds.frames[:frames], progress=progress)
    run = res.run
    sec = run["seconds"]
    tracked = [r["seconds"] for r in run["per_frame"] if r["status"] == "tracked"]
    scoring = run["settings"]["scoring_sizes"][0]
    return {"task": "start", "dataset": str(data), "filter": run["filter"],
            "cameras": len(ds.cameras), "width": scoring[0], "height": scoring[1],
            "frames": len(run["per_frame"]), "seconds_total": sec["total"],
            "initialisation": {"evaluations": run["init_evaluations"] - run["recovery"]["evaluations"],
                               "seconds": sec["initialisation"]},
            "shape_fit": {"evaluations": run["shape_fit_evaluations"], "seconds": sec["shape_fit"]},
            "recovery": {"attempts": run["recovery"]["attempts"],
                         "evaluations": run["recovery"]["evaluations"], "seconds": sec["recovery"]},
            "tracked_frames": {"count": len(tracked), "evaluations_per_frame": run["evaluations_per_frame"],
                               "seconds_mean": sec["per_tracked_frame_mean"],
                               "seconds_median": round(float(np.median(tracked)), 4) if tracked else None},
            "peak_rss_mb": round(_peak_mb(), 1), "load_average": load, **_common()}


def rank_agreement(a: np.ndarray, b: np.ndarray) -> float:
    """Spearman rank correlation of two weight vectors (ties broken by order)."""
    ra, rb = np.argsort(np.argsort(a)), np.argsort(np.argsort(b))
    return float(np.corrcoef(ra, rb)[0, 1])


def timed(fn, repeats: int) -> tuple[float, float]:
    """Median wall and process-CPU seconds of ``fn()`` over ``repeats`` calls after one warm-up
    call (compilation), each waited for with ``jax.block_until_ready``."""
    import jax

    jax.block_until_ready(fn())
    wall, cpu = [], []
    for _ in range(repeats):
        t, c = time.perf_counter(), time.process_time()
        jax.block_until_ready(fn())
        wall.append(time.perf_counter() - t)
        cpu.append(time.process_time() - c)
    return float(np.median(wall)), float(np.median(cpu))


def stage_timings(scene: Scene, *, chunk: int | None = 512, repeats: int = 7) -> dict:
    """Where the time of the JAX measure step goes: each compiled stage of the scorer timed alone
    on one chunk of the scene's particles, and the whole :meth:`Scorer.counts`. ``chunk`` None:
    the tracker's chunking for one call of the scene's particles (:func:`pick_chunking`), whose
    block program is then timed too (``geometry, block of K``, per chunk), and, when the scorer
    cuts the call into parts for its host threads, the call's whole geometry as
    :meth:`Scorer.counts` runs it (``geometry, P parts side by side``, per chunk; host work
    included).

    Returns ``{"chunk", "sizes", "stages": {name: (wall_s, cpu_s) per chunk}, "whole": (wall_s,
    cpu_s) for all particles}``.
    """
    from .likelihood.scorer import Scorer, make_observation, pick_chunking

    obs = make_observation(scene.masks)
    cut = pick_chunking([len(scene.particles)], chunk=chunk)
    s = Scorer(scene.cameras, scene.shape, scene.up, chunk=cut.chunk, block=cut.block)
    whole = timed(lambda: s.counts(scene.particles, obs), repeats)
    # a block's program (the tracker's geometry call) is reported per chunk of it
    stages = {name: tuple(t / chunks for t in timed(call, repeats))
              for name, (call, chunks) in s.stages(scene.particles, obs).items()}
    cuts = s._spread(s._blocks(len(scene.particles)))
    if len(cuts) > 1:
        chunks = sum(k for _, _, k, _ in cuts)

        def parts():  # each call writes into the last one's records, as counts runs it
            recs, ext = s.geometry(scene.particles, cuts=cuts)
            s._recycle(cuts, recs, s.q)
            return ext

        stages[f"geometry, {len(cuts)} parts side by side"] = tuple(t / chunks for t in timed(parts, repeats))
    return {"chunk": s.chunk, "sizes": [tuple(z) for z in s.sizes], "stages": stages, "whole": whole}
