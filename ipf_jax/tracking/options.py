"""The tracking options, each declared once: its flag, type, default, help, where it goes in the
settings, and how it is checked.

Everything that takes tracking options is built from :data:`OPTIONS`: the CLI parser of ``track``,
``compare`` and ``batch`` (:func:`ipf_jax.cli.options.add_tracking_options`), the keys of sweep
configurations and their checks (:mod:`ipf_jax.sweep`), ``run.json``'s ``settings``
(:func:`settings_doc`) and ``compare``. An option goes to one of three places (``target``):

* ``filter``: ``TrackSettings.filter_options[key]``, read by the filter that takes it (the filters
  declare their own defaults and rules, :data:`FILTER_OPTIONS`; the table adds flag and help);
* ``track``: the ``TrackSettings`` field ``key``;
* ``run``: not a setting of the tracker but of one run (``frames``, ``init_pose``).

Values are kept keyed by option ``key`` (the sweep key, the ``run.json`` key); the CLI flag is
``flag``. :func:`check_values` checks a set of values (each option's own rule, then the filter with
its budget), naming the flags or keys at fault; :func:`settings_from` turns them into a
:class:`TrackSettings`.
"""
from __future__ import annotations

from pathlib import Path
from typing import Any, Callable, NamedTuple

from ..body.limits import PRESETS, load_limits
from ..body.shape import load_shape
from ..data.dataset import MAX_FPS
from ..errors import IPFError, require
from ..filters import registry
from ..geometry.world import AXES
from ..likelihood.scorer import DEFAULT_CHUNK, KERNELS
from ..paths import expand_path
from .settings import (
    DEFAULT_FPS,
    DEFAULT_RESOLUTION,
    INIT_BUDGETS,
    TrackSettings,
    init_settings,
)
from .loss import LEVELS
from .shape_fit import ShapeFitSettings

#: filter name -> the option keys it takes (its settings fields; ``particles`` for every one)
FILTER_OPTIONS = registry.OPTIONS


class Option(NamedTuple):
    """One tracking option (see module doc).

    kind : int, float, bool, str, choice, dofs, path, limits, axis, range, frames.
    default : the value when not given; None = the filter's or the tracker's own default.
    check : value -> None, raising IPFError (message only; the caller says where).
    """

    key: str
    flag: str
    kind: str
    default: Any
    help: str
    target: str = "track"
    choices: tuple = ()
    check: Callable[[Any], None] | None = None
    metavar: str | None = None


def _at_least(lo, what=""):
    def check(v):
        require(v >= lo, f"must be >= {lo}{what}")
    return check


def _within(lo, hi, unit=""):
    def check(v):
        require(lo <= v <= hi, f"must be {lo:g}..{hi:g}{unit}")
    return check


#: a chunk is padded to its full size: 2^16 particles are far beyond any filter's call, and a chunk
#: of 10^9 asked for hundreds of GB
MAX_CHUNK = 1 << 16


def _lean_sigma(v):
    require(v == 0 or 0.5 <= v <= 90, "must be 0 (off) or 0.5..90 deg")


def _seed(v):
    require(0 <= v < 2 ** 32, f"must be 0..{2 ** 32 - 1} (a 32-bit unsigned integer)")


def _positive(v):
    require(v > 0 and v != float("inf"), "must be > 0 and finite")


def _limits(v):
    load_limits(v)  # a missing or bad file is an IPFError naming the file


def _shape(v):
    load_shape(v)  # a missing, damaged or out-of-bounds file is an IPFError naming the file


def _range(v):
    require(len(v) == 2 and v[0] <= v[1], "must be LO,HI with LO <= HI")
    require(-0.5 <= v[0] and v[1] <= 2.0, "the lowest point of the body must stay within -0.5..2 m "
            "of the floor (metres, not centimetres?)")


def _filter_default(name: str, key: str) -> str:
    d = registry.defaults(name).get(key)
    return "" if d is None else f" (default {d if not isinstance(d, tuple) else ','.join(d)})"


OPTIONS: tuple[Option, ...] = (
    # -- the filter and its budget
    Option("filter", "--filter", "choice", registry.DEFAULT, "the filter: ipf (the paper's), fipf "
           "(factored IPF, docs/fipf.md), apf or sir (default " + registry.DEFAULT + ")",
           choices=registry.NAMES),
    Option("budget", "--budget", "int", None, "likelihood evaluations per frame; each filter maps it "
           "onto its own sizes (IPF: M = budget // I)", check=_at_least(1)),
    Option("particles", "--particles", "int", None, "particles: IPF N = M x I (the largest M that "
           "fits), APF per layer, SIR in all", "filter"),
    Option("top_m", "--top-m", "int", None, "IPF and FIPF: M, distinct particles kept per frame "
           "(FIPF: per group)" + _filter_default("ipf", "top_m"), "filter"),
    Option("points_per_dof", "--points-per-dof", "int", None, "IPF and FIPF: grid points per "
           "searched DOF" + _filter_default("ipf", "points_per_dof") + "; I = points ** |L|", "filter"),
    Option("rounds", "--rounds", "int", None, "FIPF: passes over all groups per frame, each finer "
           "by --shrink" + _filter_default("fipf", "rounds"), "filter", check=_at_least(1)),
    Option("shrink", "--shrink", "float", None, "FIPF: interval width multiplier from one round to "
           "the next (default 1/3)", "filter", check=_within(0.01, 1.0)),
    Option("polish", "--polish", "int", None, "FIPF: compass sweeps from the best particle after "
           "the rounds, inside the budget (0: none; docs/fipf.md)" + _filter_default("fipf", "polish"),
           "filter", check=_at_least(0)),
    Option("posture", "--posture", "bool", None, "FIPF: the posture group, the pelvis moved "
           "forward, up and pitched with both feet held (rising from a chair; default on with 3 "
           "cameras or more; --no-posture: the groups alone, docs/fipf.md)", "filter"),
    Option("reach", "--reach", "bool", None, "FIPF: the arms' reach search, one arm a frame over "
           "its whole range from the frame's best pose, inside the budget (an arm the track got "
           "wrong; default on with 2 cameras or more; --no-reach: off, docs/fipf.md)", "filter"),
    Option("speed_scale", "--speed-scale", "float", None, "FIPF: multiply every DOF's maximum "
           "speed (the interval half-width is speed / fps; default 1)", "filter", check=_positive),
    Option("interval_width_deg", "--interval-width", "float", None, "IPF: full interval width, "
           "degrees per frame (overrides --max-speed)", "filter", metavar="DEG"),
    Option("max_speed_deg_s", "--max-speed", "float", None, "IPF: maximum angular speed of the "
           "interesting DOFs, deg/s; the interval is 2 x speed / fps"
           + _filter_default("ipf", "max_speed_deg_s"), "filter", metavar="DEG_S"),
    Option("interesting", "--interesting", "dofs", None, "IPF: the DOFs of L, comma-separated "
           "(default: the four hip and knee flexions)", "filter", metavar="DOF,DOF,..."),
    Option("noise_scale", "--noise-scale", "float", None, "multiply every filter's per-DOF noise "
           "rates (default 1)", "filter"),
    Option("layers", "--layers", "int", None, "APF: annealing layers" + _filter_default("apf", "layers"),
           "filter"),
    Option("survival", "--survival", "float", None, "APF: target effective particle fraction per "
           "layer" + _filter_default("apf", "survival"), "filter"),
    Option("noise_decay", "--noise-decay", "float", None, "APF: noise std multiplier from one layer "
           "to the next (default: sqrt of the survival fraction)", "filter"),
    # -- the observation
    Option("resolution", "--resolution", "int", DEFAULT_RESOLUTION, "long side of the scoring images, "
           f"px (default {DEFAULT_RESOLUTION})", check=_within(16, 2048, " px"), metavar="PX"),
    Option("fps", "--fps", "float", None, f"frame rate, Hz (default: the dataset's, else {DEFAULT_FPS:g})",
           check=_within(0.01, MAX_FPS, " Hz")),  # time_s has 6 decimals: 100 us at 10 kHz
    Option("up_axis", "--up", "axis", None, "the world's up axis, one of " + " ".join(AXES)
           + " (default: detected from the cameras)", choices=AXES, metavar="AXIS"),
    # -- the body
    Option("height_m", "--height", "float", None, "the subject's standing height, m (default: "
           "searched at initialisation)", check=_within(0.5, 2.6, " m"), metavar="M"),
    Option("shape_file", "--shape", "path", None, "the subject's shape file, e.g. a calibration "
           "run's shape.json: fixes the body (no shape search; --height must agree with it within "
           "1 cm) (default: the template adult, its height and proportions searched)",
           check=_shape, metavar="FILE"),
    Option("shape_frames", "--shape-frames", "int", ShapeFitSettings().frames, "fit the subject's "
           "proportions with the poses of K frames spread over the recording before tracking "
           f"(default {ShapeFitSettings().frames}; 0: the template's proportions, only the height "
           "searched on the first frame; not done with --init-pose or --shape; docs/shape_fit.md)",
           check=_at_least(0), metavar="K"),
    Option("passes", "--passes", "int", 1, "2: track, re-fit the shape on the tracked frames, "
           "track again (offline; pass 1's files in OUT/pass1) (default 1)", choices=(1, 2)),
    Option("limits", "--limits", "limits", "default", "DOF limits: a preset (" + ", ".join(PRESETS)
           + ") or a JSON file (default: default)", check=_limits, metavar="NAME|FILE"),
    Option("floor_range", "--floor-range", "range", None, "floor contact (off by default): keep the "
           "body's lowest point LO..HI m above the floor, e.g. --floor-range=-0.03,0.10 (with '=', "
           "as the value starts with '-')", check=_range, metavar="LO,HI"),
    # -- the search
    Option("init_budget", "--init-budget", "choice", "default", "effort of the automatic "
           "initialisation: default (the full search) or small (~10x cheaper, and no shape fit "
           "unless --shape-frames is given: quick looks, tests)",
           choices=tuple(INIT_BUDGETS)),
    Option("confidence_drop", "--confidence-drop", "float", 0.5, "re-initialise when the best "
           "weight falls below this fraction of its recent median (default 0.5)",
           check=_within(0.0, 1.0)),
    Option("confidence_patience", "--confidence-patience", "int", 2, "... for this many frames in a "
           "row (default 2)", check=_at_least(1)),
    Option("loss_test", "--loss-test", "bool", True, "the absolute loss test: a frame where the "
           "estimate explains too little of a camera's silhouette, or lies too much off it, for "
           "2 frames in a row starts a recovery, and is written as lost (nan rows, best guess in "
           "run.json) when that fails (default on; --no-loss-test: only the relative confidence, "
           "as before)"),
    Option("lost_explained", "--lost-explained", "float", LEVELS.explained, "loss test: lowest share "
           f"Nc/(Nc+Ns) of a camera's silhouette the estimate must cover (default {LEVELS.explained:g})",
           check=_within(0.0, 1.0), metavar="SHARE"),
    Option("lost_covered", "--lost-covered", "float", LEVELS.covered, "loss test: lowest share "
           f"Nc/(Nc+Nm) of the estimate that must lie on a camera's silhouette (default "
           f"{LEVELS.covered:g})", check=_within(0.0, 1.0), metavar="SHARE"),
    Option("recovery_retry", "--recovery-retry", "int", 3, "while the track is lost, a recovery "
           "attempt every K frames (default 3)", check=_at_least(1), metavar="K"),
    Option("origin_shift", "--origin-shift", "bool", True, "body origin positioning from the "
           "silhouettes between frames (default on; --no-origin-shift turns it off)"),
    Option("facing_travel", "--facing-travel", "bool", True, "the automatic initialisation of a "
           "walker searches only the headings within 90 deg of the way the silhouettes' floor point "
           "travels over the next second (when it moves steadily 0.3 m or more; default on; "
           "--no-facing-travel: every heading, e.g. for someone walking backwards)"),
    Option("pelvis_prior_deg", "--pelvis-prior", "float", 0.0, "a weak prior that the pelvis is "
           "level: every weight times exp(-roll^2 / 2 sigma^2), sigma in degrees, e.g. 20 for "
           "walking trials (silhouettes barely see the pelvis's sideways tilt; default 0: off, "
           "the silhouette likelihood alone)", check=_within(0.0, 90.0, " deg"), metavar="SIGMA"),
    Option("height_from_view", "--height-from-view", "bool", False, "with ONE calibrated camera "
           "and no height given (--height, dataset.json), use the standing height measured from the "
           "silhouettes' lowest and highest points over the floor on 15 frames, when the person stays "
           "upright (default off: the height is searched at initialisation; the camera's height "
           "above the floor must be right; otherwise a warning says why it is not measured; "
           "docs/single_camera.md)"),
    Option("lean_prior_deg", "--lean-prior", "float", 10.0, "with ONE camera, a prior that the "
           "person stands upright along its line of sight, which one view cannot see: every weight "
           "times exp(-(trunk^2 + legs^2) / 2 sigma^2) of the trunk's and the legs' lean towards or "
           "away from the camera, sigma in degrees (default 10; 0: off; ignored with several "
           "cameras)", check=_lean_sigma, metavar="SIGMA"),
    # -- the computation
    Option("seed", "--seed", "int", 0, "random seed: the same seed gives the same files (default 0)",
           check=_seed),
    Option("chunk", "--chunk", "int", None, "particles per chunk of a compiled call: memory vs speed, "
           f"never the result (default {DEFAULT_CHUNK}, or what the filter's calls fit better: IPF's "
           "416, 16 to a call; the factored filter's 216)", check=_within(1, MAX_CHUNK)),
    Option("threads", "--threads", "int", None, "host threads running the compiled programs at "
           "once: speed, never the result (default: the CPU cores this process may use; 1 on a GPU)",
           check=_at_least(1)),
    Option("kernel", "--kernel", "choice", "scanline", "raster kernel: scanline (default) or dense; "
           "both give the same pixel counts", choices=KERNELS),
    Option("checkpoint_every", "--checkpoint-every", "int", 10, "write a checkpoint (and run.json) "
           "every K frames (default 10)", check=_at_least(1), metavar="K"),
    # -- one run
    Option("frames", "--frames", "frames", None, "frame numbers to track: A:B (B excluded), A:, "
           "A:B:S or A (default: all)", "run", metavar="A:B"),
    Option("init_pose", "--init-pose", "path", None, "start from this pose instead of the automatic "
           "initialisation: a poses.csv-convention file (first row) or bodytrack's InitialPose.txt",
           "run", metavar="FILE"),
)
BY_KEY = {o.key: o for o in OPTIONS}
FILTER_KEYS = tuple(o.key for o in OPTIONS if o.target == "filter")
TRACK_KEYS = tuple(o.key for o in OPTIONS if o.target == "track")


def check_value(key: str, value, where: str, path=None) -> None:
    """One option's own rule. The IPFError names ``where`` and the value (``--height 3.5:
    outside 0.5..2.6 m``), or, given ``path`` (a config file), the file with ``where`` in the
    message; a file the option names (a limits file) is named itself."""
    opt = BY_KEY[key]
    if value is None:
        return
    try:
        if opt.choices and value not in opt.choices:
            raise IPFError(f"unknown {key.replace('_', ' ')} {value!r} (choose "
                           f"{', '.join(map(str, opt.choices))})")
        if opt.check is not None:
            opt.check(value)
    except IPFError as e:
        if e.path is not None:
            raise
        if path is None:
            raise IPFError(e.message, f"{where} {_show(value)}") from None
        raise IPFError(f"{where} {e.message}", path) from None


def split(values: dict) -> tuple[dict, dict, dict]:
    """(filter options, track fields, run values) of a values dict keyed by option key; None
    values dropped."""
    given = {k: v for k, v in values.items() if v is not None}
    unknown = sorted(set(given) - set(BY_KEY))
    require(not unknown, f"unknown tracking option(s) {', '.join(unknown)}")
    pick = lambda target: {k: v for k, v in given.items() if BY_KEY[k].target == target}  # noqa: E731
    return pick("filter"), pick("track"), pick("run")


def check_values(values: dict, *, name: Callable[[str], str] = lambda k: BY_KEY[k].flag,
                 path=None) -> None:
    """Every option's rule, then the filter with its budget (without building it). Errors name
    the options at fault by ``name(key)`` (default: the CLI flags)."""
    for key, value in values.items():
        if value is not None:
            check_value(key, value, name(key), path)
    filt, track, _ = split(values)
    if track.get("shape_file") and track.get("height_m") is not None:
        fixed = load_shape(track["shape_file"]).height_m
        if abs(track["height_m"] - fixed) > 0.01:
            raise IPFError(f"{name('height_m')} {track['height_m']} disagrees with the shape file's "
                           f"height_m {fixed:.3f} by more than 1 cm (a shape file fixes the body: "
                           "drop the height or fit a new shape)", track["shape_file"])
    if track.get("passes") == 2 and track.get("shape_file"):
        raise IPFError("--passes 2 re-fits the shape: it cannot be used with a fixed shape",
                       f"{name('passes')} 2 {name('shape_file')} {track['shape_file']}")
    fps = track.get("fps") or DEFAULT_FPS
    try:
        registry.resolve(track.get("filter", registry.DEFAULT), filt, fps, budget=track.get("budget"))
    except IPFError as e:
        given = " ".join(f"{name(k)} {_show(values[k])}" for k in ("filter", "budget", *FILTER_KEYS)
                         if values.get(k) is not None)
        raise IPFError(e.message, path or given or None) from None


def _show(v) -> str:
    return ",".join(map(str, v)) if isinstance(v, (tuple, list)) else str(v)


def defaults() -> dict:
    """Every option's default, keyed by option key."""
    return {o.key: o.default for o in OPTIONS}


def settings_from(values: dict, *, init_pose=None) -> TrackSettings:
    """:class:`TrackSettings` from values keyed by option key (missing keys: the defaults).

    init_pose : (D,) the starting pose when ``values["init_pose"]`` named a file (the caller reads
    it: a bodytrack pose needs the analysis layer to be fitted to our body).
    """
    filt, track, _ = split({**defaults(), **values})
    if "interesting" in filt:
        filt["interesting"] = tuple(filt["interesting"])
    if "floor_range" in track:
        track["floor_range"] = tuple(track["floor_range"])
    init_budget = track.pop("init_budget", "default")
    init = init_settings(init_budget)
    frames = track.pop("shape_frames", ShapeFitSettings().frames)
    if init_budget == "small" and values.get("shape_frames") is None:
        frames = 0  # a quick look: no shape fit unless asked for
    shape_fit = ShapeFitSettings(frames=frames)
    return TrackSettings(filter_options=filt, init=init, init_pose=init_pose, shape_fit=shape_fit,
                         **track)


def settings_doc(settings: TrackSettings) -> dict:
    """``run.json``'s ``settings``: every tracking option's value, keyed by option key (``init``:
    the initialisation's full settings beside the ``init_budget`` preset they come from)."""
    doc = {k: settings.filter_options.get(k) for k in FILTER_KEYS}
    for key in TRACK_KEYS:
        if key == "init_budget":
            doc[key] = next((n for n in INIT_BUDGETS if init_settings(n) == settings.init), "custom")
            doc["init"] = settings.init._asdict()
        elif key == "shape_frames":
            doc[key] = settings.shape_fit.frames
        else:
            value = getattr(settings, key)
            doc[key] = list(value) if isinstance(value, tuple) else value
    if doc.get("interesting") is not None:
        doc["interesting"] = list(doc["interesting"])
    return doc


def resolve_path(value: str, base: Path) -> str:
    """A file option's value relative to ``base`` (a config's folder); presets stay names."""
    return value if value in PRESETS else str(expand_path(value, base))
