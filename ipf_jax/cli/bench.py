"""``ipf-jax bench``: throughput of the measure step (JAX vs NumPy) and tracking s/frame (:mod:`ipf_jax.profiling`)."""
from __future__ import annotations

import warnings
from pathlib import Path

from ..errors import IPFError, IPFWarning, require
from ..filters.registry import MAX_EVALUATIONS
from ..profiling import (
    BACKENDS,
    DATASET,
    PEER_POSES,
    bench_measure,
    bench_start,
    bench_track,
    device_line,
    load_scene,
    machine,
)
from ..tracking.options import check_value
from .options import add_common, add_option, flag


#: Datasets whose default runs' one-off stages the bench times (under mocap_walk_render).
START_SETS = ("rajagopal_walk_clean_4cam", "rajagopal_walk_clean_1cam")


# -- the command -----------------------------------------------------------------------------------
def _ints(text: str) -> list[int]:
    try:
        return [int(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise IPFError(f"expected comma-separated integers, got {text!r}") from None


def _start_path(value: str, shared: Path) -> Path:
    """A start record's dataset: a folder, or a name under <shared data>/mocap_walk_render."""
    path = Path(value)
    if not path.exists():
        path = shared / "mocap_walk_render" / value
    require(path.is_dir(), f"no dataset {value!r} (a folder, or a set of <shared data>/mocap_walk_render)")
    return path


#: the options ``--quick`` replaces, with their defaults (a value given with --quick is ignored)
QUICK_SETS = {"widths": "160,320,640", "cameras": "1,4", "particles": "1024,6561,16384"}


def warn_quick_overrides(args) -> None:
    """One warning naming the options ``--quick`` replaces that were given other values."""
    given = [f"--{k}" for k, default in QUICK_SETS.items() if getattr(args, k) != default]
    if given:
        warnings.warn(IPFWarning(f"--quick measures 320 px, 1 camera, 1024 particles: "
                                 f"{', '.join(given)} ignored (drop --quick to use them)"))


def add_parser(sub) -> None:
    p = sub.add_parser("bench", help="throughput of the measure step (JAX vs NumPy) and tracking s/frame")
    add_common(p, "json", help="output file: a JSON list of records")
    p.add_argument("--data", help=f"bodytrack sequence folder (default: <shared data>/{DATASET})")
    p.add_argument("--quick", action="store_true", help="small subset: 320x240, 1 camera, 1024 particles")
    p.add_argument("--backends", default=",".join(BACKENDS), help="comma-separated measure-step "
                   "backends (default: all of " + ", ".join(BACKENDS) + ")")
    p.add_argument("--widths", default=QUICK_SETS["widths"], help="scoring widths (height: 3/4)")
    add_common(p, "cameras", default=QUICK_SETS["cameras"],
               help="camera counts, comma-separated (default 1,4)")
    add_option(p, "particles", type=str, default=QUICK_SETS["particles"],
               help="particle counts of the JAX backends, comma-separated (default 1024,6561,16384)")
    p.add_argument("--numpy-particles", type=int, default=512, help="poses for numpy-scanline")
    p.add_argument("--reference-particles", type=int, default=8, help="poses for numpy-reference")
    p.add_argument("--repeats", type=int, default=3, help="timed repeats per record (default 3)")
    add_option(p, "budget", type=float, default=60.0, help="seconds per record after which the "
               "repeats stop (default 60)")
    add_option(p, "chunk", help="particles per compiled call (default: the scorer's)")
    add_option(p, "threads", help="host threads running the compiled programs at once (default: "
               "the scorer's)")
    p.add_argument("--track-widths", default="320",
                   help="scoring widths for the tracking records (ipf 6561 and apf 4000x5); '' = none")
    p.add_argument("--start-sets", default=",".join(START_SETS),
                   help="datasets (folders, or names under <shared data>/mocap_walk_render) whose "
                        "default run's one-off stages are timed apart from its tracked frames: "
                        "automatic initialisation, shape fit, recoveries ('' = none; default "
                        + ", ".join(START_SETS) + ")")
    p.add_argument("--start-frames", type=int, default=12, help="frames of each start record's run "
                   "(default 12)")
    p.add_argument("--cold", action="store_true", help="disable the persistent compilation cache")
    p.set_defaults(func=run)


def _check_sizes(args, widths: list[int], cams: list[int], counts: list[int]) -> None:
    """Widths, camera and particle counts, repeats: each within what a bench can measure."""
    require(all(16 <= w <= 2048 for w in widths), "widths must be 16..2048 px")
    require(all(c >= 1 for c in cams) and all(n >= 1 for n in counts) and args.repeats >= 1
            and args.numpy_particles >= 1 and args.reference_particles >= 1,
            "cameras, particles and repeats must be >= 1")
    big = max(counts + [args.numpy_particles, args.reference_particles])
    require(big <= MAX_EVALUATIONS, f"{big} particles in one measure step: more than a frame's "
            f"{MAX_EVALUATIONS} evaluations (gigabytes of particles); measure fewer")


def run(args) -> int:
    from tqdm import tqdm

    from ..data.runfiles import check_output_file, write_json_atomic
    from ..paths import shared_data_dir

    data = Path(args.data) if args.data else shared_data_dir() / DATASET
    require((data / "InitialPose.txt").exists(), "not a bodytrack sequence (no InitialPose.txt)", data)
    out = check_output_file(Path(args.json))
    require(args.budget > 0, f"--budget must be > 0 seconds (got {args.budget})")
    backends = [b.strip() for b in args.backends.split(",") if b.strip()]
    bad = [b for b in backends if b not in BACKENDS]
    require(not bad, f"unknown backend(s) {', '.join(bad)} (choose from {', '.join(BACKENDS)})")
    widths, cams, counts = _ints(args.widths), _ints(args.cameras), _ints(args.particles)
    track_widths = _ints(args.track_widths)
    starts = [] if args.quick else [_start_path(v.strip(), shared_data_dir())
                                     for v in args.start_sets.split(",") if v.strip()]
    require(args.start_frames >= 2, f"--start-frames must be >= 2 (got {args.start_frames})")
    _check_sizes(args, widths + track_widths, cams, counts)
    # measure-step records (--quick: one case of its own sizes), else only tracking or start ones
    measures = bool(backends) and (args.quick or bool(widths and cams and counts))
    empty = [f"--{k}" for k, v in (("widths", widths), ("cameras", cams), ("particles", counts),
                                   ("backends", backends)) if not v]
    require(measures or (not args.quick and bool(track_widths or starts)),
            f"{', '.join(empty)} names no value and no --track-widths or --start-sets are given: "
            "nothing would be measured")
    from ..data.dataset import open_dataset

    have = len(open_dataset(data).cameras)  # before the first record, not in its middle
    require(args.quick or not cams or max(cams) <= have,
            f"--cameras {args.cameras}: the data set has {have} cameras", data)
    for key in ("chunk", "threads"):  # the tracking options' own rules, before any work
        if getattr(args, key) is not None:
            check_value(key, getattr(args, key), flag(key))
    if args.quick:  # after the checks: --quick does not hide a bad value
        warn_quick_overrides(args)
        widths, cams, counts, track_widths = [320], [1], [1024], []
    if args.cold:
        import jax

        jax.config.update("jax_enable_compilation_cache", False)
    host = machine()
    print(device_line(), flush=True)
    records: list[dict] = []
    jobs = [(w, c) for w in widths for c in cams] if measures else []
    bar = tqdm(total=len(jobs) * len(backends) + 2 * len(track_widths) + len(starts), desc="bench",
               unit="case")
    for width, n_cam in jobs:
        scene = load_scene(data, width, n_cam, max(counts + [args.numpy_particles]))
        for backend in backends:
            sizes = {"numpy-scanline": [args.numpy_particles],
                     "numpy-reference": [args.reference_particles]}.get(backend, counts)
            for n in sizes:
                rec, _ = bench_measure(backend, scene, n, repeats=args.repeats, budget_s=args.budget,
                                       chunk=args.chunk, threads=args.threads)
                records.append({**rec, "machine": host})
                write_json_atomic(out, records)  # partial results survive an interruption
                bar.set_postfix(last=f"{backend} {width} {n_cam}cam {n}: {rec['particles_per_s']:.0f}/s")
            bar.update()
    peer = data.parent / Path(PEER_POSES).name
    for width in track_widths:
        for filt in ("ipf", "apf"):
            rec = bench_track(data, filt, width, peer=peer)
            records.append({**rec, "machine": host})
            write_json_atomic(out, records)
            bar.set_postfix(last=f"track {filt} {width}: {rec['seconds_per_frame']} s/frame")
            bar.update()
    for path in starts:
        rec = bench_start(path, args.start_frames)
        records.append({**rec, "machine": host})
        write_json_atomic(out, records)
        bar.set_postfix(last=f"start {path.name}: init {rec['initialisation']['seconds']} s, "
                             f"shape fit {rec['shape_fit']['seconds']} s")
        bar.update()
    bar.close()
    print(f"wrote {len(records)} records to {out}")
    return 0
