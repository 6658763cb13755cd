"""A stop asked for by a signal, honoured by long loops at their next step.

The CLI turns SIGTERM (a batch scheduler's stop, ``kill``) into :class:`Terminated`, raised where
the interpreter stands, so a run unwinds like Ctrl-C: it keeps its rows and checkpoint and says so.
An exception raised by a signal handler can be lost, though: raised inside a ``__del__`` method or
a callback that C code calls and does not propagate from, Python prints it as "Exception ignored"
and carries on, and the run would finish as if nothing had been asked (seen once in CI). So
:func:`request` also records the request, and the tracker's frame loop calls :func:`check` each
frame: a stop whose exception went astray still ends the run one frame later.
"""
from __future__ import annotations

import threading

_REQUESTED = threading.Event()


class Terminated(KeyboardInterrupt):
    """SIGTERM (a batch scheduler's stop, ``kill``): unwound like Ctrl-C, so a run keeps its rows
    and checkpoint and says so, instead of dying where it stands."""


def request() -> None:
    """Record a stop and raise :class:`Terminated` here (a signal handler's body)."""
    _REQUESTED.set()
    raise Terminated()


def check() -> None:
    """Raise :class:`Terminated` if a stop was asked for (by :func:`request`) and not cleared."""
    if _REQUESTED.is_set():
        raise Terminated()


def clear() -> None:
    """Forget a stop asked for (a command has ended: the next one in this process starts clean)."""
    _REQUESTED.clear()
