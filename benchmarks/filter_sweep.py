"""IPF, factored IPF, APF and SIR at equal likelihood budgets on several visible walks, 3 seeds.

    python benchmarks/filter_sweep.py --out DIR [--sets A,B] [--budgets 2000,6561,20000]
                                      [--seeds 0,1,2] [--frames 0:16] [--backend local|ray]

1. *Shared starts*: for each set, ``ipf-jax track SET --frames F:F+1`` (the automatic
   initialisation, filter-independent) gives the first pose and the height; every cell of that set
   starts from them, so the cells differ only by filter, budget and seed.
2. Writes ``DIR/sweep.toml`` (one ``[[dataset]]`` per set with its start, one ``[[filter]]`` per
   filter over the budgets) and runs ``ipf-jax sweep DIR/sweep.toml --out DIR/sweep``: resumable,
   cells already done are kept.
3. Tabulates, per filter and budget, the MPJPE (12 limb joints) averaged over the sets, its mean
   and standard error over the seeds, and, per set, the same: ``DIR/filters_budgets.md``,
   ``DIR/filters_budgets.json`` and the figure ``DIR/filters_budgets.png`` (mean +- s.e.).

Data: ``../shared/data/mocap_walk_render`` (or ``$IPF_JAX_DATA``), real mocap rendered by a
non-capsule renderer, so no cell scores the tracker against its own model.
"""
from __future__ import annotations

import argparse
import csv
import json
import subprocess
import sys
from pathlib import Path

import numpy as np

from ipf_jax.paths import shared_data_dir

FILTERS = ("ipf", "fipf", "apf", "sir")
IPF_JAX = str(Path(sys.executable).with_name("ipf-jax"))  # the CLI installed beside this Python
DEFAULT_SETS = "rajagopal_walk_clean_4cam,sub4_walk_clean_4cam,rajagopal_longlegs_noisy_4cam"


def start_of(root: Path, name: str, first: int, out: Path) -> tuple[Path, float]:
    """The automatic initialisation's pose file and height for set ``name`` (run once, kept)."""
    run = out / "starts" / name
    if not (run / "poses.csv").is_file():
        subprocess.run([IPF_JAX, "track", str(root / name), "--frames",
                        f"{first}:{first + 1}", "--out", str(run)], check=True)
    height = json.loads((run / "shape.json").read_text())["height_m"]
    return run / "poses.csv", float(height)


def write_config(path: Path, root: Path, sets: list[str], starts: dict, budgets: list[int],
                 seeds: list[int], frames: str) -> None:
    lines = ["# written by benchmarks/filter_sweep.py", "[sweep]", f'frames = "{frames}"',
             f"seed = {seeds}", "resolution = 320", ""]
    for name in sets:
        pose, height = starts[name]
        lines += ["[[dataset]]", f'name = "{name}"', f'path = "{root / name}"',
                  f'truth = "{root / name / "ground_truth.csv"}"', f'init_pose = "{pose}"',
                  f"height_m = {height:.4f}", ""]
    for f in FILTERS:
        lines += ["[[filter]]", f'name = "{f}"', f"budget = {budgets}", ""]
    path.write_text("\n".join(lines))


def tabulate(summary_csv: Path, out: Path) -> dict:
    """Mean and standard error over seeds of the set-averaged MPJPE, per filter and budget."""
    rows = [r for r in csv.DictReader(summary_csv.open()) if r["status"] == "ok" and r["mpjpe_m"]]
    cells: dict = {}
    for r in rows:
        key = (r["filter"], int(r["budget"]))
        cells.setdefault(key, {}).setdefault(int(r["seed"]), {})[r["dataset"]] = 1000 * float(r["mpjpe_m"])
    table = {}
    for (filt, budget), by_seed in sorted(cells.items(), key=lambda kv: (kv[0][1], FILTERS.index(kv[0][0]))):
        sets = sorted(set.intersection(*(set(d) for d in by_seed.values())))
        per_seed = np.array([np.mean([d[s] for s in sets]) for d in by_seed.values()])
        se = per_seed.std(ddof=1) / np.sqrt(len(per_seed)) if len(per_seed) > 1 else float("nan")
        per_set = {s: float(np.mean([d[s] for d in by_seed.values()])) for s in sets}
        table[f"{filt}@{budget}"] = {"filter": filt, "budget": budget, "seeds": len(per_seed),
                                     "sets": sets, "mean_mm": float(per_seed.mean()), "se_mm": float(se),
                                     "per_set_mm": per_set}
    (out / "filters_budgets.json").write_text(json.dumps(table, indent=1))
    sets = sorted({s for t in table.values() for s in t["sets"]})
    md = ["| budget | filter | seeds | MPJPE mean ± s.e. (mm) | " + " | ".join(sets) + " |",
          "|---|---|---|---|" + "---|" * len(sets)]
    for t in table.values():
        md.append(f"| {t['budget']} | {t['filter']} | {t['seeds']} | {t['mean_mm']:.1f} ± {t['se_mm']:.1f} | "
                  + " | ".join(f"{t['per_set_mm'].get(s, float('nan')):.1f}" for s in sets) + " |")
    (out / "filters_budgets.md").write_text("\n".join(md) + "\n")
    return table


def plot(table: dict, path: Path) -> None:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(6.5, 4.2), dpi=110)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(1, 1, 1)
    for filt, colour in zip(FILTERS, ("tab:blue", "tab:purple", "tab:orange", "tab:green")):
        pts = sorted((t["budget"], t["mean_mm"], t["se_mm"]) for t in table.values() if t["filter"] == filt)
        if pts:
            b, m, e = map(np.array, zip(*pts))
            ax.errorbar(b, m, yerr=e, marker="o", capsize=3, color=colour, label=filt)
    ax.set_xscale("log")
    ax.set_xlabel("likelihood evaluations per frame")
    ax.set_ylabel("MPJPE, 12 limb joints (mm)")
    ax.set_title("equal budgets, mean ± s.e. over seeds (mocap_walk_render)", fontsize=9)
    ax.grid(alpha=0.3, which="both")
    ax.legend()
    fig.tight_layout()
    fig.savefig(path)


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--out", type=Path, required=True)
    p.add_argument("--sets", default=DEFAULT_SETS)
    p.add_argument("--budgets", default="2000,6561,20000")
    p.add_argument("--seeds", default="0,1,2")
    p.add_argument("--frames", default="0:16")
    p.add_argument("--backend", default="local", choices=("local", "ray"))
    a = p.parse_args(argv)
    root = shared_data_dir() / "mocap_walk_render"
    sets = [s.strip() for s in a.sets.split(",") if s.strip()]
    budgets = [int(b) for b in a.budgets.split(",")]
    seeds = [int(s) for s in a.seeds.split(",")]
    a.out.mkdir(parents=True, exist_ok=True)
    first = int(a.frames.split(":")[0] or 0)
    starts = {s: start_of(root, s, first, a.out) for s in sets}
    config = a.out / "sweep.toml"
    write_config(config, root, sets, starts, budgets, seeds, a.frames)
    subprocess.run([IPF_JAX, "sweep", str(config), "--out", str(a.out / "sweep"),
                    "--backend", a.backend], check=True)
    table = tabulate(a.out / "sweep" / "summary.csv", a.out)
    plot(table, a.out / "filters_budgets.png")
    print((a.out / "filters_budgets.md").read_text())


if __name__ == "__main__":
    main()
