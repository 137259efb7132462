"""Work spread over spawned processes with a progress bar: the grasp trials and the
convex decompositions run through the same pool."""

from __future__ import annotations

import os
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from typing import Any

__all__ = ["progress_bar", "run_in_processes"]

_THREAD_VARS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


@contextmanager
def _one_thread_each() -> Iterator[None]:
    """One BLAS/OpenMP thread per process while the pool starts: the processes
    are the parallelism."""
    saved = {k: os.environ.get(k) for k in _THREAD_VARS}
    for k in _THREAD_VARS:
        os.environ[k] = "1"
    try:
        yield
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


#: a job whose process dies this many times is given up (``on_crash``)
MAX_ATTEMPTS = 2


def run_in_processes(
    fn: Callable[..., Any],
    jobs: Sequence[tuple[Any, ...]],
    workers: int,
    on_done: Callable[[int, Any], None],
    *,
    order: Sequence[int] | None = None,
    initializer: Callable[[], None] | None = None,
    on_crash: Callable[[int], None] | None = None,
) -> None:
    """``fn(*jobs[i])`` for each ``i`` of ``order`` (default: all, in order) in
    ``workers`` spawned processes; ``on_done(i, result)`` as each finishes.

    A process that dies (a crash in a compiled library, the out-of-memory killer)
    costs only the jobs it was running: the pool is started again and they are
    tried again; a job whose process dies ``MAX_ATTEMPTS`` times is handed to
    ``on_crash(i)`` (raised as an error without one). Any other error from ``fn``
    cancels what has not started and is raised.
    """
    import multiprocessing
    from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
    from concurrent.futures.process import BrokenProcessPool

    todo = list(range(len(jobs)) if order is None else order)
    attempts = dict.fromkeys(todo, 0)
    with _one_thread_each():
        ctx = multiprocessing.get_context("spawn")
        while todo:
            crashed: list[int] = []
            with ProcessPoolExecutor(
                workers, mp_context=ctx, initializer=initializer
            ) as ex:
                pending = {ex.submit(fn, *jobs[i]): i for i in todo}
                try:
                    while pending:
                        done, _ = wait(pending, return_when=FIRST_COMPLETED)
                        for fut in done:
                            i = pending.pop(fut)
                            try:
                                result = fut.result()
                            except BrokenProcessPool:
                                crashed.append(i)
                                continue
                            on_done(i, result)
                except BaseException:
                    for fut in pending:
                        fut.cancel()
                    raise
            todo = []
            for i in crashed:
                attempts[i] += 1
                if attempts[i] < MAX_ATTEMPTS:
                    todo.append(i)
                elif on_crash is not None:
                    on_crash(i)
                else:
                    raise BrokenProcessPool(
                        f"job {i} crashed its process {attempts[i]} times"
                    )


@contextmanager
def progress_bar(
    enabled: bool, label: str, total: int
) -> Iterator[Callable[[str], None]]:
    """A rich progress bar on stderr (a no-op when disabled); yields
    ``advance(status)``, one step with a status text."""
    if not enabled:
        yield lambda _status: None
        return
    from rich.console import Console
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    bar = Progress(
        TextColumn(f"[bold]{label}"),
        BarColumn(),
        MofNCompleteColumn(),
        TextColumn("{task.fields[status]}"),
        TimeElapsedColumn(),
        TimeRemainingColumn(),
        console=Console(stderr=True),
    )
    with bar:
        task = bar.add_task(label, total=total, status="")
        yield lambda status: bar.update(task, advance=1, status=status)
