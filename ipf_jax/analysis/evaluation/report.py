"""Files of an evaluation: ``eval.json``, ``per_frame.csv`` and the displacement figure."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ...data.runfiles import JointsTable, check_writable, write_json_atomic
from .metrics import Evaluation, summary_doc


def per_frame_rows(ev: Evaluation) -> list[str]:
    """CSV lines: ``frame,time_s,scored,mpjpe_m,<name>_m...`` (nan where not computable)."""
    lines = [",".join(["frame", "time_s", "scored", "mpjpe_m"] + [f"{n}_m" for n in ev.names])]
    s_idx = [ev.names.index(n) for n in ev.scored]
    for t in range(len(ev.frame)):
        frame_err = ev.errors[t, s_idx].mean() if ev.scored_frames[t] else np.nan
        values = [frame_err] + list(np.where(ev.inside[t], ev.errors[t], np.nan))
        lines.append(f"{int(ev.frame[t])},{ev.time_s[t]:.6f},{int(ev.scored_frames[t])},"
                     + ",".join("nan" if not np.isfinite(v) else f"{v:.6f}" for v in values))
    return lines


def write_outputs(ev: Evaluation, truth: JointsTable, out_dir: str | Path, *, plots: bool = True,
                  extra: dict | None = None) -> list[Path]:
    """Write eval.json (:func:`summary_doc` + ``extra``), per_frame.csv and, with ``plots``,
    displacement.png into ``out_dir``; returns the paths written."""
    out = check_writable(Path(out_dir))
    doc = summary_doc(ev)
    doc.update(extra or {})
    write_json_atomic(out / "eval.json", doc)
    (out / "per_frame.csv").write_text("\n".join(per_frame_rows(ev)) + "\n")
    written = [out / "eval.json", out / "per_frame.csv"]
    if plots:
        from .plots import plot_displacement

        fig = plot_displacement(ev, truth, out / "displacement.png")
        written += [fig] if fig is not None else []
    return written
