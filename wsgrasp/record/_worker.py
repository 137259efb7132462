"""The process's writer thread, and the recordings it has yet to finish."""

from __future__ import annotations

import atexit
import os
import queue
import threading
import weakref
from collections.abc import Callable
from contextlib import suppress
from typing import Any

__all__ = ["OPEN", "PENDING", "REGISTRY", "start", "submit", "wait_for_recorders"]

#: Recorders with a file still open (finished at interpreter exit), and those whose
#: file the writer thread is finishing; ``REGISTRY`` guards both.
OPEN: weakref.WeakSet[Any] = weakref.WeakSet()
PENDING: weakref.WeakSet[Any] = weakref.WeakSet()
REGISTRY = threading.Lock()

_jobs: queue.SimpleQueue[Callable[[], None]] = queue.SimpleQueue()
_thread: threading.Thread | None = None
_lock = threading.Lock()


def start() -> None:
    """Start the process's writer thread, unless it runs: one thread runs every
    recorder's jobs in order (starting one can take milliseconds on a busy
    machine)."""
    global _thread
    with _lock:
        if _thread is None or not _thread.is_alive():
            _thread = threading.Thread(target=_serve, name="wsgrasp-recorder")
            _thread.daemon = True
            _thread.start()


def _serve() -> None:
    while True:
        _jobs.get()()


def submit(job: Callable[[], None]) -> None:
    """Run ``job`` on the writer thread, after the jobs before it."""
    start()
    _jobs.put(job)


def wait_for_recorders() -> None:
    """Wait until the writer thread has finished every recording handed to it
    (a new recording calls this before its plan starts)."""
    with REGISTRY:
        pending = list(PENDING)
    for rec in pending:
        rec.wait()


def _forget_after_fork() -> None:
    """In a forked child: the parent's recordings are the parent's to finish (a
    child finishing them at exit would write into the parent's files), and the
    writer thread was not copied."""
    global REGISTRY, _jobs, _thread, _lock
    REGISTRY = threading.Lock()  # another thread may have held it at the fork
    _jobs, _thread, _lock = queue.SimpleQueue(), None, threading.Lock()
    OPEN.clear()
    PENDING.clear()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_forget_after_fork)


@atexit.register
def _close_open_recorders() -> None:
    """A recorder left open (no result, no error reported) is finished at exit."""
    with REGISTRY:
        still_open = list(OPEN)
    for rec in still_open:
        with suppress(Exception):  # exiting anyway
            rec.close()
