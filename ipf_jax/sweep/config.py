"""Sweep configuration (TOML) -> the list of cells, validated before anything runs.

::

    [sweep]                 # settings shared by every filter: scalar = fixed, list = swept
    frames = "0:12"
    seed = [0, 1]
    resolution = 320

    [[dataset]]             # one or more; relative paths are relative to this file
    name = "clean_4cam"     # optional (default: the folder name)
    path = "data/walk"
    truth = "data/walk/ground_truth.csv"   # optional: cells then report MPJPE
    init_pose = "pose0.csv"                # optional poses.csv-convention file (first row)

    [[filter]]              # one or more; name = ipf | apf | sir, the rest are its value lists
    name = "ipf"
    interval_width_deg = [5.0, 10.0, 20.0]
    top_m = [10, 20, 40]

    [eval]                  # optional
    joints = ["left_knee", "right_knee"]   # default: the 12 limb joints
    align = "none"

Cells are the product, per dataset and filter block, of every listed value (in file order). Every
user mistake (unknown key, wrong type, missing file, an option the filter does not take, a budget
too small for the grid) is one IPFError naming this file before any cell runs.
"""
from __future__ import annotations

import itertools
from pathlib import Path
from typing import NamedTuple

from ..errors import IPFError, require
from ..filters.registry import NAMES as FILTERS
from .spec import (
    OPTION_TYPES,
    TRACK_TYPES,
    Cell,
    check_filter,
    check_frames,
    coerce,
    make_cell,
    resolve,
)

DATASET_KEYS = ("name", "path", "truth", "init_pose", "frames", "height_m", "up_axis", "fps")
EVAL_KEYS = ("joints", "align")


class SweepConfig(NamedTuple):
    path: Path
    cells: list[Cell]
    datasets: list[str]
    filters: list[str]


def read_toml(path: Path) -> dict:
    try:
        import tomllib
    except ModuleNotFoundError:  # Python 3.10
        import tomli as tomllib
    try:
        with open(path, "rb") as fh:
            return tomllib.load(fh)
    except FileNotFoundError:
        raise IPFError("config file not found", path) from None
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as e:
        raise IPFError(f"not a readable TOML file ({e})", path) from None


def _unknown(table: dict, allowed, where: str, path: Path) -> None:
    extra = [k for k in table if k not in allowed]
    require(not extra, f"{where}: unknown key(s) {', '.join(extra)} (known: {', '.join(allowed)})", path)


def _values(key: str, value, *, base: Path, where: str, path: Path) -> list:
    """A setting's value list: a TOML array is swept, a scalar is fixed (one value)."""
    is_list = isinstance(value, list) and not (key == "interesting" and value
                                                and all(isinstance(v, str) for v in value))
    items = value if is_list else [value]
    require(bool(items), f"{where}: {key} is an empty list", path)
    if key == "frames":
        return [check_frames(v, where=where, path=path) for v in items]
    return [coerce(key, v, base=base, where=where, path=path) for v in items]


def _dataset(entry, k: int, base: Path, path: Path) -> dict:
    where = f"[[dataset]] {k}"
    require(isinstance(entry, dict), f"{where} must be a table", path)
    _unknown(entry, DATASET_KEYS, where, path)
    require(isinstance(entry.get("path"), str), f"{where} needs a path = \"folder\"", path)
    folder = resolve(entry["path"], base)
    require(folder.is_dir(), f"{where}: dataset folder not found: {folder}", path)
    out = {"dataset": str(folder), "name": entry.get("name") or folder.name}
    require(isinstance(out["name"], str), f"{where}: name must be a string", path)
    for key in ("truth", "init_pose"):
        if key in entry:
            require(isinstance(entry[key], str), f"{where}: {key} must be a file path", path)
            f = resolve(entry[key], base)
            require(f.is_file(), f"{where}: {key} file not found: {f}", path)
            out[key] = str(f)
    fixed = {}
    for key in ("frames", "height_m", "up_axis", "fps"):
        if key in entry:
            require(not isinstance(entry[key], list), f"{where}: {key} must be a single value", path)
            fixed[key] = _values(key, entry[key], base=base, where=where, path=path)[0]
    return {**out, "fixed": fixed}


def load_config(path: str | Path) -> SweepConfig:
    """Read and validate a sweep TOML; returns every cell in a stable order (see module doc)."""
    path = Path(path)
    try:
        return _load_config(path)
    except IPFError as e:  # every error names the config file (a path in it may be the problem)
        if e.path is not None:
            raise
        raise IPFError(e.message, path) from None


def _load_config(path: Path) -> SweepConfig:
    doc = read_toml(path)
    base = path.resolve().parent
    _unknown(doc, ("sweep", "dataset", "filter", "eval"), "top level", path)
    shared = doc.get("sweep", {})
    require(isinstance(shared, dict), "[sweep] must be a table", path)
    _unknown(shared, tuple(TRACK_TYPES) + ("frames",), "[sweep]", path)
    datasets, filters = doc.get("dataset"), doc.get("filter")
    require(isinstance(datasets, list) and datasets, "needs at least one [[dataset]] table", path)
    require(isinstance(filters, list) and filters, "needs at least one [[filter]] table", path)
    ev = doc.get("eval", {})
    require(isinstance(ev, dict), "[eval] must be a table", path)
    _unknown(ev, EVAL_KEYS, "[eval]", path)
    joints = ev.get("joints")
    require(joints is None or (isinstance(joints, list) and all(isinstance(j, str) for j in joints)),
            "[eval]: joints must be a list of names", path)
    align = ev.get("align", "none")
    require(align in ("none", "rigid"), f"[eval]: align must be none or rigid (got {align!r})", path)
    data = [_dataset(e, k, base, path) for k, e in enumerate(datasets, start=1)]
    names = [d["name"] for d in data]
    require(len(set(names)) == len(names), f"two [[dataset]] tables share a name: give each a "
            f"distinct name = \"...\" ({', '.join(names)})", path)
    cells: dict[str, Cell] = {}
    checked = set()
    for f_no, block in enumerate(filters, start=1):
        where = f"[[filter]] {f_no}"
        require(isinstance(block, dict), f"{where} must be a table", path)
        require(block.get("name") in FILTERS, f"{where}: name must be one of {', '.join(FILTERS)} "
                f"(got {block.get('name')!r})", path)
        settings = {k: v for k, v in block.items() if k != "name"}
        _unknown(settings, tuple(OPTION_TYPES) + tuple(TRACK_TYPES) + ("frames",), where, path)
        axes = {k: _values(k, v, base=base, where=where if k in settings else "[sweep]", path=path)
                for k, v in {**shared, **settings}.items()}
        keys = list(axes)
        for d in data:
            for combo in itertools.product(*(axes[k] for k in keys)):
                values = {**dict(zip(keys, combo)), **d["fixed"]}
                varying = {k: values[k] for k in keys if len(axes[k]) > 1}
                spec = {"dataset": d["dataset"], "name": d["name"], "truth": d.get("truth"),
                        "init_pose": d.get("init_pose"), "frames": values.pop("frames", None),
                        "filter": block["name"],
                        "options": {k: v for k, v in values.items() if k in OPTION_TYPES},
                        "track": {k: v for k, v in values.items() if k in TRACK_TYPES},
                        "eval": {"joints": joints, "align": align}}
                desc = f"{where} ({block['name']}) with " + (", ".join(f"{k}={v}" for k, v in values.items())
                                                             or "defaults")
                key = repr((spec["filter"], spec["options"], spec["track"]))
                if key not in checked:
                    check_filter(spec, where=desc, path=path)
                    checked.add(key)
                cell = make_cell(spec, varying)
                cells.setdefault(cell.id, cell)
    _check_data(list(cells.values()), path)
    return SweepConfig(path, list(cells.values()), names, [b["name"] for b in filters])


def _check_data(cells, path: Path) -> None:
    """What only the data can say, before any cell runs: every cell's frame range selects frames
    of its recording, and every truth file reads as a joints CSV."""
    from ..data.dataset import open_dataset
    from ..data.frames import parse_frames, select_frames
    from ..data.runfiles import read_joints_csv

    frames_of: dict = {}
    done = set()
    for cell in cells:
        spec = cell.spec
        key = (spec["dataset"], spec["frames"])
        if spec["frames"] is not None and key not in done:
            done.add(key)
            if spec["dataset"] not in frames_of:
                frames_of[spec["dataset"]] = open_dataset(spec["dataset"]).frames
            try:
                select_frames(frames_of[spec["dataset"]], parse_frames(spec["frames"]), warn=False)
            except IPFError as e:
                raise IPFError(f"{spec['name']}: {e.message}", path) from None
        if spec.get("truth") and spec["truth"] not in done:
            done.add(spec["truth"])
            try:
                read_joints_csv(spec["truth"])
            except IPFError as e:
                raise IPFError(f"{spec['name']}: truth: {e}", path) from None
