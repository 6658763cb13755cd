"""Options shared by the commands that track (``track``, ``compare``, ``batch``) and their
translation into :class:`ipf_jax.tracking.tracker.TrackSettings`."""
from __future__ import annotations

import argparse
from pathlib import Path

from ..data.runfiles import read_pose_rows
from ..errors import IPFError, require


def _slice(text: str) -> slice:
    from ..data.frames import parse_frames

    try:
        return parse_frames(text)
    except IPFError as e:
        raise argparse.ArgumentTypeError(e.message) from None


def _range(text: str) -> tuple[float, float]:
    try:
        lo, hi = (float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"--floor-range must look like LO,HI in metres (got {text!r})") from None
    if not lo <= hi:
        raise argparse.ArgumentTypeError(f"--floor-range needs LO <= HI (got {text!r})")
    return lo, hi


def add_tracking_options(p: argparse.ArgumentParser) -> None:
    """Options shared by track, compare, and the sweep/batch configs."""
    p.add_argument("--filter", default="ipf", help="ipf (default), apf or sir")
    p.add_argument("--budget", type=int, help="likelihood evaluations per frame; each filter maps it onto its parameters")
    p.add_argument("--particles", type=int, help="IPF: total particles N = M x I (largest M that fits)")
    p.add_argument("--top-m", type=int, help="IPF: M, the distinct particles kept per frame (default 81)")
    p.add_argument("--points-per-dof", type=int, help="IPF: grid points per interesting DOF (default 3 -> I = 81)")
    p.add_argument("--interval-width", type=float,
                   help="IPF: full interval width in degrees per frame (overrides --max-speed)")
    p.add_argument("--max-speed", type=float, help="IPF: maximum angular speed of the interesting DOFs, deg/s")
    p.add_argument("--interesting", help="IPF: comma-separated DOF names forming L (default: the 4 leg flexions)")
    p.add_argument("--noise-scale", type=float, help="multiply the default per-DOF noise rates")
    p.add_argument("--layers", type=int, help="APF: annealing layers (default 5)")
    p.add_argument("--resolution", type=int, default=None, help="long side of the scoring images, px (default 320)")
    p.add_argument("--fps", type=float, help="frame rate (default: from the video, else 20 Hz)")
    p.add_argument("--height", type=float, help="subject height in metres (default: searched at initialisation)")
    p.add_argument("--shape", help="subject shape JSON (default adult, scaled by --height)")
    p.add_argument("--limits", default="default", help="DOF limits preset (default, walking) or JSON file")
    p.add_argument("--up", help="world up axis (+x -x +y -y +z -z; default detected)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--chunk", type=int, default=512, help="particles per compiled call")
    p.add_argument("--kernel", default="scanline", choices=["scanline", "dense"])
    p.add_argument("--frames", type=_slice, help="frame numbers A:B (B excluded), A:, A:B:S or A")
    p.add_argument("--init-budget", default="default", choices=["default", "small"],
                   help="effort of the automatic initialisation: small searches ~10x fewer "
                        "configurations (quick looks, tests); default is the full search")
    p.add_argument("--init-pose", help="initial pose: poses.csv row file, or bodytrack InitialPose.txt")
    p.add_argument("--floor-range", type=_range, default=None, metavar="LO,HI",
                   help="floor contact constraint (off by default): keep the body's lowest surface "
                        "point LO..HI m above the floor, e.g. --floor-range=-0.03,0.10 (with '=': "
                        "the value starts with '-') (see ipf_jax.tracking.contact)")


def filter_options(args) -> dict:
    opts = {}
    if getattr(args, "top_m", None) is not None:
        opts["top_m"] = args.top_m
    if getattr(args, "particles", None) is not None:
        opts["particles"] = args.particles
    if getattr(args, "points_per_dof", None) is not None:
        opts["points_per_dof"] = args.points_per_dof
    if getattr(args, "interval_width", None) is not None:
        opts["interval_width_deg"] = args.interval_width
    if getattr(args, "max_speed", None) is not None:
        opts["max_speed_deg_s"] = args.max_speed
    if getattr(args, "interesting", None):
        opts["interesting"] = tuple(s.strip() for s in args.interesting.split(",") if s.strip())
    if getattr(args, "noise_scale", None) is not None:
        opts["noise_scale"] = args.noise_scale
    if getattr(args, "layers", None) is not None:
        opts["layers"] = args.layers
    return opts


#: track/compare flags that shape the filter, named in its errors (``dest``: flag).
_FILTER_FLAGS = {"filter": "--filter", "budget": "--budget", "particles": "--particles",
                 "top_m": "--top-m", "points_per_dof": "--points-per-dof",
                 "interval_width": "--interval-width", "max_speed": "--max-speed",
                 "interesting": "--interesting", "noise_scale": "--noise-scale", "layers": "--layers"}


def check_settings(args) -> None:
    """Build the filter (and scale the body) once before any data is read: an impossible setting
    fails at once, and the error names the flags that were given (the filters' own messages name
    the parameter only)."""
    from ..body.limits import load_limits
    from ..body.shape import default_shape
    from ..filters import registry

    if args.height is not None:
        try:
            default_shape().scaled_to(args.height)
        except IPFError as e:
            raise IPFError(e.message, f"--height {args.height}") from None

    given = " ".join(f"{flag} {getattr(args, dest)}" for dest, flag in _FILTER_FLAGS.items()
                     if getattr(args, dest, None) is not None)
    limits = load_limits(args.limits)  # its errors name the limits file
    fps = args.fps if args.fps and args.fps > 0 else 20.0  # the rate is checked with the dataset
    try:
        registry.make(args.filter, filter_options(args), limits, fps, budget=args.budget)
    except IPFError as e:
        raise IPFError(e.message, given) from None


def floor_range(args) -> tuple[float, float] | None:
    """``--floor-range LO,HI`` -> TrackSettings.floor_range (None: no floor contact)."""
    return getattr(args, "floor_range", None)


def initial_pose(args):
    """(q, height) from --init-pose: a poses CSV (first row) or a bodytrack InitialPose.txt."""
    path = Path(args.init_pose)
    if path.suffix.lower() == ".txt":
        from ..analysis.bodytrack import fit_our_pose, read_body_shape, read_pose
        from ..analysis.bodytrack.kinematics import bodytrack_points

        shape_file = path.parent / "BodyShapeParameters.txt"
        require(shape_file.exists(), "a bodytrack pose needs BodyShapeParameters.txt beside it", path)
        pose = read_pose(path)[0]
        fit = fit_our_pose(bodytrack_points(pose, read_body_shape(shape_file)), up=args.up or "+z",
                           height_m=args.height)
        return fit.q, fit.height_m
    return read_pose_rows(path)[0], args.height


#: ``track --init-budget``: the full search, or a ~10x cheaper one (one height when given,
#: 8 headings, one refinement round) for quick looks and end-to-end tests.
INIT_BUDGETS = {
    "default": None,
    "small": dict(headings=8, position_steps=0, modes=1, keep=8, refine_rounds=1,
                  refine_particles=64, pattern_keep=2, pattern_sweeps=1),
}


def init_settings(args):
    """``--init-budget`` -> :class:`ipf_jax.tracking.initialise.InitSettings`."""
    from ..tracking.initialise import InitSettings

    return InitSettings(**(INIT_BUDGETS[getattr(args, "init_budget", "default")] or {}))
