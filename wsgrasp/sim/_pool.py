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

    At most ``workers`` jobs are in flight, so a process that dies (a crash in a
    compiled library, the out-of-memory killer) can only have been running one of
    them. The pool fails every job in flight, including one no process had taken
    up yet, so each of those is run again alone, in a process of its own, and
    once more if that process dies too (a job that never ran before may have died
    alone for the first time); a job whose process dies both times alone is handed
    to ``on_crash(i)`` (raised as an error without one). Then the pool starts
    again for the rest. Any other error from ``fn`` cancels what has not started
    and is raised.
    """
    from concurrent.futures.process import BrokenProcessPool

    todo = list(range(len(jobs)) if order is None else order)
    with _one_thread_each():
        while todo:
            suspects = _run_pool(fn, jobs, todo, workers, on_done, initializer)
            finished = set(todo) - set(suspects.unstarted) - set(suspects.running)
            todo = [i for i in todo if i not in finished and i not in suspects.running]
            for i in suspects.running:  # alone, so that a crash names its job
                for _ in range(2):
                    if not _run_pool(fn, jobs, [i], 1, on_done, initializer).running:
                        break
                else:
                    if on_crash is None:
                        raise BrokenProcessPool(
                            f"job {i} crashed its process twice when run alone"
                        )
                    on_crash(i)


class _Broken:
    """What a pool left undone when a process died."""

    def __init__(self, running: list[int], unstarted: list[int]) -> None:
        self.running = running
        self.unstarted = unstarted


def _run_pool(
    fn: Callable[..., Any],
    jobs: Sequence[tuple[Any, ...]],
    todo: Sequence[int],
    workers: int,
    on_done: Callable[[int, Any], None],
    initializer: Callable[[], None] | None,
) -> _Broken:
    """One pool over ``todo``, at most ``workers`` jobs in flight; returns the jobs
    in flight and those not started when a process died (both empty if none)."""
    import multiprocessing
    from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
    from concurrent.futures.process import BrokenProcessPool

    ctx = multiprocessing.get_context("spawn")
    queue = list(todo)[::-1]  # popped from the end: in order
    with ProcessPoolExecutor(workers, mp_context=ctx, initializer=initializer) as ex:
        pending: dict[Any, int] = {}
        try:
            while queue or pending:
                while queue and len(pending) < workers:
                    i = queue.pop()
                    pending[ex.submit(fn, *jobs[i])] = i
                done, _ = wait(pending, return_when=FIRST_COMPLETED)
                broken: list[int] = []
                for fut in done:
                    i = pending.pop(fut)
                    try:
                        result = fut.result()
                    except BrokenProcessPool:
                        broken.append(i)
                        continue
                    on_done(i, result)
                if broken:
                    running = broken + list(pending.values())
                    return _Broken(running, queue[::-1])
        except BaseException:
            for fut in pending:
                fut.cancel()
            raise
    return _Broken([], [])


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
