"""Frame ranges: one syntax for every ``--frames`` option and every ``frames`` entry of a file.

A range is ``"A"`` (one frame), ``"A:B"``, ``"A:"``, ``":B"`` or ``"A:B:S"`` over frame *numbers*
(B excluded, as a Python slice; S > 0), or ``[A, B]`` in JSON files. :func:`select_frames` picks
the frames of a recording that a range names; when the range names frames the recording does not
have, it warns once with the frames actually used (an :class:`ipf_jax.errors.IPFWarning`, which
the CLI prints as one ``warning:`` line) rather than tracking fewer frames without a word.
"""
from __future__ import annotations

import warnings
from pathlib import Path
from typing import Sequence

from ..errors import IPFError, IPFWarning, require

FORMS = '"A", "A:B", "A:" or "A:B:S" (frame numbers, B excluded)'


def parse_frames(value, where: str = "frames", path: str | Path | None = None) -> slice:
    """A frame range (see module doc) -> ``slice`` of frame numbers; IPFError names ``where``."""
    if isinstance(value, slice):
        return value
    if isinstance(value, (list, tuple)) and len(value) == 2 \
            and all(isinstance(v, int) and not isinstance(v, bool) for v in value):
        return slice(value[0], value[1])
    if isinstance(value, str):
        try:
            parts = [int(p) if p.strip() else None for p in value.split(":")]
        except ValueError:
            parts = []
        if len(parts) == 1 and parts[0] is not None:
            return slice(parts[0], parts[0] + 1)
        if 2 <= len(parts) <= 3 and (len(parts) < 3 or parts[2] is None or parts[2] > 0):
            require(parts[0] is None or parts[1] is None or parts[1] > parts[0],
                    f"{where} {value!r} selects no frame (B is excluded: it must be above A)", path)
            return slice(*parts)
    forms = FORMS + ("" if where.startswith("--") else " or [A, B]")
    raise IPFError(f"{where} must be {forms}, got {value!r}", path)


def describe(sl: slice) -> str:
    """The range as the user writes it (``30:40``, ``5:``, ``0:32:2``)."""
    text = f"{'' if sl.start is None else sl.start}:{'' if sl.stop is None else sl.stop}"
    return text + (f":{sl.step}" if sl.step not in (None, 1) else "")


def select_frames(frames: Sequence[int], sl: slice | None, *, where: str = "frames",
                  path: str | Path | None = None, warn: bool = True) -> list[int]:
    """The frame numbers of ``frames`` that ``sl`` names, in order.

    The step counts from the range's start (or from the first frame when the start is open).
    None for ``sl`` selects every frame. A range that selects none is an IPFError; one that asks
    for frames the recording lacks warns once (``warn``) naming the frames it uses.
    """
    frames = [int(f) for f in frames]
    if sl is None or not frames:
        return frames
    step = sl.step or 1
    if step <= 0:
        raise IPFError(f"{where} {describe(sl)}: the step must be positive", path)
    lo = sl.start if sl.start is not None else frames[0]
    hi = sl.stop if sl.stop is not None else max(frames) + 1
    chosen = [f for f in frames if lo <= f < hi and (f - lo) % step == 0]
    span = f"{min(frames)}..{max(frames)}"
    if not chosen:
        raise IPFError(f"{where} {describe(sl)} selects none of the frames ({span})", path)
    wanted = len(range(lo, hi, step))
    if warn and len(chosen) < wanted:
        used = f"{chosen[0]}..{chosen[-1]}" if len(chosen) > 1 else f"{chosen[0]}"
        warnings.warn(IPFWarning(f"{where} {describe(sl)} asks for {wanted} frames but the recording "
                                 f"has frames {span}: using {len(chosen)} ({used})"), stacklevel=2)
    return chosen
