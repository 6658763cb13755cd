"""Command-line options, each declared once.

The tracking options come from their table (:data:`ipf_jax.tracking.options.OPTIONS`: flag, type,
default, help, check); :data:`COMMON` declares the flags several commands share (``--out``,
``--quiet``, ...). A command adds an option with :func:`add_option` / :func:`add_common`, giving
only what differs for it (a help text, ``required``). Argument values are collected keyed by option
key (:func:`values_from_args`), checked (:func:`check_args`) and turned into
:class:`~ipf_jax.tracking.settings.TrackSettings` by :func:`settings_from_args`.
"""
from __future__ import annotations

import argparse
from pathlib import Path

from ..data.frames import parse_frames
from ..data.runfiles import read_pose_rows
from ..errors import IPFError, require
from ..tracking.options import BY_KEY, OPTIONS, Option, check_values, settings_from

#: Flags several commands share: name -> (flag, argparse keywords). A command overrides any keyword.
COMMON = {
    "out": ("--out", {"required": True, "help": "output folder (created)"}),
    "quiet": ("--quiet", {"action": "store_true", "help": "no progress bar"}),
    "json": ("--json", {"required": True, "help": "output JSON file"}),
    "dataset": ("--dataset", {"help": "the dataset folder (default: the one named in run.json)"}),
    "cameras": ("--cameras", {"help": "cameras by name or 1-based number, comma-separated "
                                      "(default: all)"}),
    "units": ("--units", {"help": "length unit of the file"}),
    "backend": ("--backend", {"help": "where the work runs"}),
    "camera": ("--camera", {"help": "one camera, by name or 1-based number"}),
    "masks": ("--masks", {"action": "store_true", "help": "work on the silhouette masks"}),
    "size": ("--size", {"help": "image size"}),
    "smooth": ("--smooth", {"action": "store_true", "help": "also the joints low-passed by the gait "
                            "analysis' zero-lag filter (5 Hz, at most fps/4); raw joints kept"}),
}


def _comma_floats(text: str) -> tuple[float, float]:
    try:
        lo, hi = (float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"must look like LO,HI in metres (got {text!r})") from None
    if not lo <= hi:
        raise argparse.ArgumentTypeError(f"needs LO <= HI (got {text!r})")
    return lo, hi


def _frames(text: str) -> slice:
    try:
        return parse_frames(text, BY_KEY["frames"].flag)
    except IPFError as e:
        raise argparse.ArgumentTypeError(e.message) from None


def _dofs(text: str) -> tuple[str, ...]:
    return tuple(s.strip() for s in text.split(",") if s.strip())


_TYPES = {"int": int, "float": float, "range": _comma_floats, "frames": _frames, "dofs": _dofs}


def add_option(p: argparse.ArgumentParser, opt: Option | str, **override) -> None:
    """Add one tracking option (by key or :class:`Option`) to a parser, ``dest`` = its key.

    Defaults stay None on the command line (so the given ones can be named in errors); the
    table's defaults apply when the settings are built.
    """
    opt = BY_KEY[opt] if isinstance(opt, str) else opt
    kw = {"dest": opt.key, "default": None, "help": opt.help}
    if opt.kind == "bool":
        kw["action"] = argparse.BooleanOptionalAction
    else:
        kw["type"] = _TYPES.get(opt.kind, str)
        if opt.metavar:
            kw["metavar"] = opt.metavar
    if opt.choices and "metavar" not in kw:  # checked by the table (one error line, not argparse's)
        kw["metavar"] = "{" + ",".join(map(str, opt.choices)) + "}"
    kw.update(override)
    p.add_argument(opt.flag, **kw)


def add_tracking_options(p: argparse.ArgumentParser, *, exclude: tuple[str, ...] = ()) -> None:
    """Every tracking option (:data:`OPTIONS`) but those in ``exclude``."""
    for opt in OPTIONS:
        if opt.key not in exclude:
            add_option(p, opt)


def add_common(p: argparse.ArgumentParser, name: str, **override) -> None:
    """Add a shared flag of :data:`COMMON` (``dest`` = its name), with ``override`` keywords."""
    flag, kw = COMMON[name]
    p.add_argument(flag, dest=name, **{**kw, **override})


def flag(key: str) -> str:
    """The command-line flag of a tracking option or a common flag."""
    return BY_KEY[key].flag if key in BY_KEY else COMMON[key][0]


def values_from_args(args: argparse.Namespace) -> dict:
    """The tracking options the command line gave (option key -> value; absent ones left out)."""
    return {o.key: getattr(args, o.key) for o in OPTIONS if getattr(args, o.key, None) is not None}


def check_args(args: argparse.Namespace) -> dict:
    """Check the given tracking options before any data is read (each option's rule, then the
    filter with its budget); errors name the flags. Returns the values."""
    values = values_from_args(args)
    check_values(values)
    return values


def initial_pose(values: dict) -> tuple:
    """(q (D,) or None, height or None) from ``init_pose``: a poses CSV (first row) or bodytrack's
    InitialPose.txt, fitted to our body (its height found unless ``height_m`` is given)."""
    if not values.get("init_pose"):
        return None, values.get("height_m")
    path = Path(values["init_pose"])
    if path.suffix.lower() == ".txt":
        from ..analysis.bodytrack import fit_our_pose, read_body_shape, read_pose
        from ..analysis.bodytrack.kinematics import bodytrack_points

        shape_file = path.parent / "BodyShapeParameters.txt"
        require(shape_file.exists(), "a bodytrack pose needs BodyShapeParameters.txt beside it", path)
        pose = read_pose(path)[0]
        fit = fit_our_pose(bodytrack_points(pose, read_body_shape(shape_file)),
                           up=values.get("up_axis") or "+z", height_m=values.get("height_m"))
        return fit.q, fit.height_m
    return read_pose_rows(path)[0], values.get("height_m")


def settings_from_args(args: argparse.Namespace, values: dict | None = None):
    """:class:`TrackSettings` of the command line (the initial pose file read)."""
    values = values_from_args(args) if values is None else values
    q0, height = initial_pose(values)
    return settings_from({**values, "height_m": height}, init_pose=q0)
