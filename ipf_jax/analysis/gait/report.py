"""Write a :class:`~ipf_jax.analysis.gait.analysis.GaitResult` to an output folder.

Files (schema in ``docs/gait.md``): ``gait.json`` (everything, machine-readable), ``steps.csv``
(one row per step) and ``strides.csv`` (one row per gait cycle), ``displacement.png``,
``angles.png`` and ``variability.png`` (:mod:`.plots`), and ``report.html``, one self-contained
page with the figures embedded as base64 so it can be mailed or archived alone.
"""
from __future__ import annotations

import base64
import html
import json
from pathlib import Path

import numpy as np

from ...errors import IPFError
from .angles import CYCLE_SAMPLES
from .parameters import SIDES, STEP_BOUNDS, STRIDE_BOUNDS, Step, Stride
from .plots import plot_angles, plot_displacement, plot_variability

FORMAT = "ipf-jax-gait"
VERSION = 1
ANGLE_NAMES = {"hip": "hip_flexion_deg", "knee": "knee_flexion_deg",
               "ankle": "ankle_dorsiflexion_deg"}


def to_json(result) -> dict:
    """The ``gait.json`` document of a result (plain Python types, NaN written as null)."""
    longest = max(result.parts, key=lambda p: p.end_s - p.start_s)
    curves = {"cycle_pct": list(range(CYCLE_SAMPLES))}
    for side in SIDES:
        curves[side] = {}
        for joint, cycles in result.curves[side].items():
            if len(cycles):
                curves[side][ANGLE_NAMES[joint]] = {
                    "n": len(cycles), "mean": _floats(cycles.mean(axis=0)),
                    "sd": _floats(cycles.std(axis=0, ddof=1)) if len(cycles) > 1 else None,
                    "cycles": [_floats(c) for c in cycles]}
    return {
        "format": FORMAT, "version": VERSION, "source": result.source, "method": result.method,
        "fps": result.fps, "up_axis": result.up_axis,
        "filter": {"type": "Butterworth, zero-phase (forward-backward)", "order": 4,
                   "cutoff_hz": result.cutoff_hz},
        "direction": _heading(longest.heading),
        "segments": [{"index": p.index, "start_s": _f(p.start_s), "end_s": _f(p.end_s),
                      "frames": len(p.time), "distance_m": _f(p.distance_m),
                      **_heading(p.heading)} for p in result.parts],
        "stand_ins": result.stand_ins,
        "events": {k: _floats(v) for k, v in result.events.items()},
        "parameters": {**result.parameters, "symmetry_index_pct": result.symmetry},
        "curves": curves,
        "counts": {"steps": len(result.steps), "strides": len(result.strides),
                   "rejected": len(result.rejected)},
        "lab": result.lab,
        "fall_risk": result.fall_risk,
        "cameras": result.cameras,
        "unobservable": result.unobservable,
        "bounds": {"step": {k: _bound(v) for k, v in STEP_BOUNDS.items()},
                   "stride": {k: _bound(v) for k, v in STRIDE_BOUNDS.items()}},
        "rejected": [{**r._asdict(), "start_s": _f(r.start_s), "end_s": _f(r.end_s)}
                     for r in result.rejected],
        "missing": result.missing,
        "notes": list(result.notes),
    }


def write_outputs(result, out_dir: str | Path) -> dict:
    """Write every output file into ``out_dir`` (created); returns name -> Path written."""
    out = Path(out_dir)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise IPFError(f"cannot create the output folder ({e})", out) from None
    doc = to_json(result)
    files = {"gait.json": out / "gait.json", "steps.csv": out / "steps.csv",
             "strides.csv": out / "strides.csv"}
    files["gait.json"].write_text(json.dumps(doc, indent=1, allow_nan=False) + "\n")
    _write_rows(files["steps.csv"], Step._fields, result.steps)
    _write_rows(files["strides.csv"], Stride._fields, result.strides)
    files["displacement.png"] = plot_displacement(result, out / "displacement.png")
    angles = plot_angles(result, out / "angles.png")
    if angles is not None:
        files["angles.png"] = angles
    variability = plot_variability(result, out / "variability.png")
    if variability is not None:
        files["variability.png"] = variability
    files["report.html"] = out / "report.html"
    files["report.html"].write_text(render_html(doc, {k: v for k, v in files.items()
                                                      if k.endswith(".png")}))
    return files


def render_html(doc: dict, images: dict) -> str:
    """One-page HTML report of a ``gait.json`` document with PNGs embedded (base64)."""
    e = html.escape
    rows = []
    for name, per in doc["parameters"].items():
        if name == "symmetry_index_pct":
            continue
        cells = "".join(f"<td>{_mean_sd(per[k])}</td>" for k in ("left", "right", "all"))
        rows.append(f"<tr><th>{e(name)}</th>{cells}</tr>")
    sym = "".join(f"<tr><th>{e(k)}</th><td>{'-' if v is None else f'{v:.1f}'}</td></tr>"
                  for k, v in doc["parameters"]["symmetry_index_pct"].items())
    events = "".join(f"<tr><th>{e(k)}</th><td>{', '.join(f'{t:.3f}' for t in v) or '-'}</td>"
                     "</tr>" for k, v in doc["events"].items())
    missing = "".join(f"<li><code>{e(k)}</code>: {e(v)}</li>" for k, v in doc["missing"].items())
    fall = "".join(_fall_row(k, v) for k, v in doc["fall_risk"].items())
    sources = sorted({v["reference"]["source"] for v in doc["fall_risk"].values()
                      if v.get("reference")})
    refs = "".join(f"<li>{e(src)}</li>" for src in sources)
    rejected = "".join(f"<li>{e(r['kind'])} {e(r['side'])} {_v(r['start_s'], '.3f')}-"
                       f"{_v(r['end_s'], '.3f')} s: {e(r['reason'])}</li>" for r in doc["rejected"])
    unobs = "".join(f"<li><code>{e(k)}</code>: {e(v)}</li>" for k, v in doc["unobservable"].items())
    lab = doc["lab"]
    head = (f"<b>Cadence</b> {_v(lab['cadence_steps_per_min'], '.1f')} steps/min "
            f"({lab['steps']} steps in {_v(lab['time_s'], '.2f')} s between the first and last "
            f"heel strike) &nbsp; <b>Walking speed</b> "
            f"{_v(doc['fall_risk']['walking_speed_m_s']['value'], '.2f')} m/s")
    notes = "".join(f"<li>{e(n)}</li>" for n in doc["notes"])
    figs = "".join(
        f'<figure><img alt="{e(k)}" src="data:image/png;base64,'
        f'{base64.b64encode(Path(p).read_bytes()).decode()}"><figcaption>{e(k)}</figcaption>'
        "</figure>" for k, p in images.items())
    d = doc["direction"]
    title = f"Gait report - {e(Path(doc['source']).name)}"
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{title}</title>
<style>body{{font-family:sans-serif;max-width:60em;margin:1em auto;padding:0 1em}}
table{{border-collapse:collapse;margin:.5em 0}}td,th{{border:1px solid #ccc;padding:.2em .6em;
text-align:right}}th{{text-align:left}}img{{max-width:100%}}figure{{margin:1em 0}}
.head{{font-size:1.2em}}</style>
</head><body>
<h1>Gait report</h1>
<p><b>Source</b> {e(doc['source'])}<br><b>Events</b> {e(doc['method'])} method,
low-pass {doc['filter']['cutoff_hz']:g} Hz, {doc['fps']:g} fps, up {e(doc['up_axis'])}<br>
<b>Walking</b> {e(d['mode'])}, forward = {e(str(d['forward']))},
{len(doc['segments'])} straight part(s), {doc['counts']['steps']} steps,
{doc['counts']['strides']} strides</p>
<p class="head">{head}</p>
<h2>Balance and fall risk</h2>
<table><tr><th>measure</th><th>value</th><th>n</th><th>reference (source below)</th><th>flag</th>
</tr>{fall}</table>
<ol>{refs}</ol>
<h2>Not observable with these cameras</h2><ul>{unobs or '<li>nothing</li>'}</ul>
<h2>Parameters (mean &plusmn; SD, n)</h2>
<table><tr><th></th><th>left</th><th>right</th><th>all</th></tr>{''.join(rows)}</table>
<h2>Symmetry index (%, 100 (R - L) / mean)</h2><table>{sym}</table>
{figs}
<h2>Events (s)</h2><table>{events}</table>
<h2>Rejected (outside the physiological bounds)</h2><ul>{rejected or '<li>nothing</li>'}</ul>
<h2>Not computed</h2><ul>{missing or '<li>nothing</li>'}</ul>
<h2>Notes</h2><ul>{notes}</ul>
</body></html>
"""


def _fall_row(name: str, m: dict) -> str:
    e = html.escape
    value = "-" if m["value"] is None else f"{m['value']:.3g} {e(m['unit'])}"
    ref = m.get("reference")
    ref_text = "" if not ref else e(ref["text"])
    note = f"<br><small>{e(m['note'])}</small>" if m.get("note") else ""
    return (f"<tr><th>{e(name)}</th><td>{value}{note}</td><td>{m['n']}</td>"
            f"<td style='text-align:left'>{ref_text}</td><td>{e(m['flag'] or '')}</td></tr>")


def _v(x, fmt: str) -> str:
    return "-" if x is None else format(x, fmt)


def _bound(b: tuple) -> list:
    return [None if not np.isfinite(x) else float(x) for x in b]


def _write_rows(path: Path, fields: tuple, rows: list) -> None:
    lines = [",".join(fields)]
    for r in rows:
        lines.append(",".join(v if isinstance(v, str) else str(v) if isinstance(v, int)
                              else f"{float(v):.6f}" for v in r))
    path.write_text("\n".join(lines) + "\n")


def _heading(h) -> dict:
    return {"mode": h.mode, "forward": _floats(h.forward), "left": _floats(h.left),
            "up": _floats(h.up)}


def _mean_sd(stat: dict) -> str:
    if stat["mean"] is None:
        return "-"
    sd = "" if stat["sd"] is None else f" &plusmn; {stat['sd']:.3f}"
    cv = "" if stat.get("cv_pct") is None else f", CV {stat['cv_pct']:.1f} %"
    return f"{stat['mean']:.3f}{sd} ({stat['n']}{cv})"


def _f(x: float) -> float | None:
    return None if not np.isfinite(x) else round(float(x), 6)


def _floats(a) -> list:
    return [_f(x) for x in np.asarray(a, dtype=float).ravel()]
