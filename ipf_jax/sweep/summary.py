"""What a sweep or batch produced: ``summary.csv``, ``summary.json`` and the error-vs-cost plot.

``summary.csv`` has one row per cell in config order: id, dataset, filter, the settings that vary
between cells, status, the filter's effective parameters, evaluations per frame, MPJPE (m, when
there is a truth), seconds per tracked frame, and the error of failed cells. Only the
:data:`TIMING_COLUMNS` depend on the machine; every other column is reproducible.

``pareto.png``: MPJPE against the median seconds per tracked frame (left) and against likelihood
evaluations per frame (right), one colour per filter, one marker per dataset; the dashed line joins
the cells no other cell beats on both error and cost (the Pareto front, per dataset).
"""
from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np

from ..data.runfiles import write_json_atomic

TIMING_COLUMNS = ("seconds_per_frame", "seconds_per_frame_median", "seconds_total")
RESULT_COLUMNS = ("status", "filter_params", "evaluations_per_frame", "init_evaluations", "frames_done",
                  "frames_missing", "reinitialisations", "mpjpe_m", "n_frames") + TIMING_COLUMNS + ("error",)
SHORT = {"top_m": "M", "interval_width_deg": "w", "points_per_dof": "P", "particles": "N", "budget": "B",
         "seed": "seed", "resolution": "res", "layers": "L", "max_speed_deg_s": "v", "noise_scale": "ns"}


def _settings(rec: dict) -> dict:
    s = rec["settings"]
    return {**s["options"], **s["track"], **({"frames": s["frames"]} if s.get("frames") else {})}


def varying_keys(records: list[dict]) -> list[str]:
    """Setting names whose value differs between records (or is missing in some), in first-seen order."""
    seen: dict[str, set] = {}
    for rec in records:
        for k, v in _settings(rec).items():
            seen.setdefault(k, set()).add(json.dumps(v))
    return [k for k, vals in seen.items()
            if len(vals) > 1 or any(k not in _settings(r) for r in records)]


def _cell_value(rec: dict, col: str):
    result, timing = rec.get("result") or {}, rec.get("timing") or {}
    if col == "status":
        return rec["status"]
    if col == "error":
        return rec["error"]["message"] if rec.get("error") else ""
    if col == "filter_params":
        params = result.get("filter_params") or {}
        return " ".join(f"{k}={v}" for k, v in params.items() if not isinstance(v, (list, tuple, dict)))
    if col == "reinitialisations":
        return len(result["reinitialisations"]) if "reinitialisations" in result else ""
    value = result.get(col, timing.get(col))
    return "" if value is None else value


def write_summary(records: list[dict], out_dir: Path) -> Path:
    """``summary.csv`` (see module doc); returns its path."""
    keys = varying_keys(records)
    path = Path(out_dir) / "summary.csv"
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["id", "dataset", "filter"] + keys + list(RESULT_COLUMNS))
        for rec in records:
            s = _settings(rec)
            w.writerow([rec["id"], rec["settings"]["name"], rec["settings"]["filter"]]
                       + [json.dumps(s[k]) if isinstance(s.get(k), list) else s.get(k, "") for k in keys]
                       + [_cell_value(rec, c) for c in RESULT_COLUMNS])
    return path


def code_versions(records: list[dict]) -> dict:
    """{code fingerprint: number of cells}: more than one key means mixed ipf_jax versions
    (cells whose worker died before reporting have no fingerprint and are not counted)."""
    out: dict[str, int] = {}
    for code in (r.get("code") for r in records):
        if code:
            out[code] = out.get(code, 0) + 1
    return out


def write_status(records: list[dict], out_dir: Path, *, kind: str, extra: dict | None = None) -> Path:
    """``summary.json``: counts, the failures and why, and what else the caller adds."""
    failed = [r for r in records if r["status"] == "failed"]
    doc = {"kind": kind, "total": len(records), "succeeded": len(records) - len(failed),
           "failed": len(failed), "code_versions": code_versions(records),
           "failures": [{"id": r["id"], "label": r["label"], "dataset": r["settings"]["dataset"],
                         "error": r["error"]} for r in failed], **(extra or {})}
    path = Path(out_dir) / "summary.json"
    write_json_atomic(path, doc)
    return path


def pareto_front(cost: np.ndarray, error: np.ndarray) -> np.ndarray:
    """(P,) indices of the points no other point beats on both (lower is better), by cost."""
    order = np.lexsort((error, cost))
    front, best = [], np.inf
    for i in order:
        if error[i] < best:
            front.append(i)
            best = error[i]
    return np.array(front, int)


def _short_label(rec: dict, keys: list[str]) -> str:
    s = _settings(rec)
    return " ".join(f"{SHORT.get(k, k)}{s[k]:g}" if isinstance(s[k], float) else f"{SHORT.get(k, k)}{s[k]}"
                    for k in keys if k in s and not isinstance(s[k], (list, dict)))


def _panel(ax, recs: list[dict], cost: np.ndarray, err: np.ndarray, colours: dict, markers: dict,
           labels: dict) -> None:
    """One error-vs-cost scatter (colour per filter, marker per dataset) with its Pareto fronts."""
    from matplotlib.ticker import NullFormatter, ScalarFormatter

    for r, x, y in zip(recs, cost, err):
        ax.plot(x, y, markers[r["settings"]["name"]], color=colours[r["settings"]["filter"]], ms=6, alpha=0.85)
        ax.annotate(labels[r["id"]], (x, y), xytext=(3, 3), textcoords="offset points", fontsize=6)
    datasets = list(dict.fromkeys(r["settings"]["name"] for r in recs))
    for d in datasets:
        idx = np.array([i for i, r in enumerate(recs) if r["settings"]["name"] == d and np.isfinite(cost[i])])
        if len(idx):
            front = idx[pareto_front(cost[idx], err[idx])]
            ax.plot(cost[front], err[front], "--", color="0.4", lw=1, zorder=0, drawstyle="steps-post")
    for f in dict.fromkeys(r["settings"]["filter"] for r in recs):
        ax.plot([], [], "o", color=colours[f], label=f.upper())
    for d in datasets if len(datasets) > 1 else []:
        ax.plot([], [], markers[d], color="0.3", label=d)
    ax.plot([], [], "--", color="0.4", label="Pareto front")
    finite = cost[np.isfinite(cost) & (cost > 0)]
    if len(finite) and finite.max() > 10 * finite.min():  # costs span decades: log axis
        ax.set_xscale("log")
        ax.xaxis.set_major_formatter(ScalarFormatter())
        ax.xaxis.set_minor_formatter(NullFormatter())
    ax.set_ylabel("MPJPE (mm)")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)


def plot_pareto(records: list[dict], path: Path, *, title: str = "") -> Path | None:
    """``pareto.png`` (see module doc); None when no successful cell has an MPJPE."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    recs = [r for r in records if r["status"] == "ok" and (r.get("result") or {}).get("mpjpe_m") is not None]
    if not recs:
        return None
    by_filter: dict[str, list] = {}
    for r in recs:
        by_filter.setdefault(r["settings"]["filter"], []).append(r)
    labels = {r["id"]: _short_label(r, varying_keys(rs)) for rs in by_filter.values() for r in rs}
    colours = dict(zip(by_filter, ["tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple"] * 4))
    markers = dict(zip(dict.fromkeys(r["settings"]["name"] for r in recs), "osD^v<>p*" * 4))
    err = np.array([1000 * r["result"]["mpjpe_m"] for r in recs])
    fig = Figure(figsize=(13, 5.5), dpi=110)
    FigureCanvasAgg(fig)
    costs = (("seconds per tracked frame (median)", [r["timing"].get("seconds_per_frame_median") for r in recs]),
             ("likelihood evaluations per frame", [r["result"]["evaluations_per_frame"] for r in recs]))
    for k, (xlabel, cost) in enumerate(costs):
        ax = fig.add_subplot(1, 2, k + 1)
        _panel(ax, recs, np.array([np.nan if c is None else c for c in cost], float), err, colours, markers,
               labels)
        ax.set_xlabel(xlabel)
    if title:
        fig.suptitle(title, fontsize=11)
    fig.tight_layout()
    fig.savefig(path)
    return Path(path)
