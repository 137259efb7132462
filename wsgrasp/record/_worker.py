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

__all__ = ["OPEN", "PENDING", "REGISTRY", "Worker", "wait_for_recorders"]

#: Recorders with a file still open (finished at interpreter exit), and those whose
#: file the writer thread is finishing; ``REGISTRY`` guards both.
OPEN: weakref.WeakSet[Any] = weakref.WeakSet()
PENDING: weakref.WeakSet[Any] = weakref.WeakSet()
REGISTRY = threading.Lock()


class Worker:
    """The process's writer thread: runs jobs in order (starting a thread can
    take milliseconds on a busy machine, so one serves every recorder)."""

    jobs: queue.SimpleQueue[Callable[[], None]] = queue.SimpleQueue()
    thread: threading.Thread | None = None
    lock = threading.Lock()

    @classmethod
    def start(cls) -> None:
        with cls.lock:
            if cls.thread is None or not cls.thread.is_alive():
                cls.thread = threading.Thread(
                    target=cls._serve, name="wsgrasp-recorder", daemon=True
                )
                cls.thread.start()

    @classmethod
    def _serve(cls) -> None:
        while True:
            cls.jobs.get()()

    @classmethod
    def submit(cls, job: Callable[[], None]) -> None:
        cls.start()
        cls.jobs.put(job)


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
    global REGISTRY
    REGISTRY = threading.Lock()  # another thread may have held it at the fork
    OPEN.clear()
    PENDING.clear()
    Worker.jobs, Worker.thread, Worker.lock = (
        queue.SimpleQueue(),
        None,
        threading.Lock(),
    )


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
