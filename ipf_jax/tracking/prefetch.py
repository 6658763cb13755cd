"""The next frame read while this one is tracked: one background thread for the tracker's
:meth:`~ipf_jax.tracking.tracker.Tracker.observe`.

Reading a frame (decoding images or videos, a background model, resizing, blobs and rays) is host
work that does not depend on the frame before it, while a tracked frame's time is mostly spent
waiting for the compiled likelihood, which runs on the device (or on XLA's own threads) and
releases the interpreter. So the tracker asks for frame t + 1 as soon as frame t's observation
is in hand, and takes it when frame t + 1 starts (:class:`Prefetch`). What a frame observes does not
change: the same function runs on the same frame, only earlier and on another thread. An error
it raises (a missing or corrupt file) is raised by :meth:`Prefetch.take`, on the main thread, at the
frame it belongs to, exactly as a direct read would raise it. A frame asked for that is not the one
read ahead (a resumed or restarted run) is read directly.

Data sets are not assumed to be thread-safe (a video capture keeps a read position): the caller
serialises its reads of the data set (the tracker holds a lock around ``Dataset.masks``), so the
thread only overlaps the rest of the work.
"""
from __future__ import annotations

from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor
from typing import Generic, TypeVar

T = TypeVar("T")


class Prefetch(Generic[T]):
    """``read(frame)`` run one frame ahead on a background thread (a context manager).

    ``start(frame)`` begins reading ``frame`` (the one before is dropped if not taken);
    ``take(frame)`` returns ``read(frame)``: the result read ahead when it is that frame's, else a
    direct read. Leaving the ``with`` block waits for a read in flight and drops it.
    """

    def __init__(self, read: Callable[[int], T]):
        self._read = read
        self._pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="ipf-jax-read")
        self._pending: tuple[int, Future] | None = None
        self.hits = 0  # frames served from the read ahead (for tests and profiles)

    def start(self, frame: int) -> None:
        if self._pending is not None and self._pending[0] == frame:
            return
        self._drop()
        self._pending = (frame, self._pool.submit(self._read, frame))

    def take(self, frame: int) -> T:
        if self._pending is not None and self._pending[0] == frame:
            future = self._pending[1]
            self._pending = None
            result = future.result()  # the thread's error is raised here, at its frame
            self.hits += 1
            return result
        self._drop()
        return self._read(frame)

    def _drop(self) -> None:
        if self._pending is not None:
            future = self._pending[1]
            self._pending = None
            if not future.cancel():
                future.exception()  # wait for it; its error belongs to a frame not tracked

    def close(self) -> None:
        self._drop()
        self._pool.shutdown(wait=True)

    def __enter__(self) -> "Prefetch[T]":
        return self

    def __exit__(self, *exc) -> None:
        self.close()
