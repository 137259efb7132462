"""Where jobs run: this process, a local pool of spawned processes, or Ray.

An engine runs ``fn(*jobs[i])`` for every job and hands each result to
``on_done(i, result)`` in the calling process as it arrives, so the caller writes
its rows as they come. What every job needs and is costly to rebuild (a gripper
model, a spec) is given once as ``shared`` and read in a job with :func:`shared`:
the local pool sends it to each process when it starts, Ray puts it in the object
store once (``ray.put``) and each worker process fetches it once.

A process that dies (SIGKILL, the out-of-memory killer, a crash in a compiled
library) costs only the job it was running: the local pool runs it again alone
(:func:`wsgrasp.sim._pool.run_in_processes`), Ray retries it (``max_retries``).
A job that kills its process every time goes to ``on_crash(i)``.

Ray is the ``ray`` extra (``pip install 'wsgrasp[ray]'``) and is imported only
when a Ray engine runs; it starts a local Ray instance of ``workers`` CPUs, or
joins the cluster at ``address``.
"""

from __future__ import annotations

import functools
import os
from collections.abc import Callable, Sequence
from typing import Any, Protocol

__all__ = [
    "ENGINES",
    "Engine",
    "LocalEngine",
    "RayEngine",
    "make_engine",
    "require_ray",
    "shared",
]

#: the engines ``--engine`` accepts
ENGINES = ("local", "ray")
#: times Ray runs a task again whose worker process died
RAY_MAX_RETRIES = 3

Job = tuple[Any, ...]
OnDone = Callable[[int, Any], None]

#: this process's shared payload (see :func:`shared`) and the key it came under
_SHARED: dict[str, Any] = {"key": None, "value": None}


def shared() -> Any:
    """The ``shared`` payload of the engine running this job (None outside one)."""
    return _SHARED["value"]


def _set_shared(key: Any, value: Any) -> None:
    _SHARED["key"] = key
    _SHARED["value"] = value


class Engine(Protocol):
    """What ``wsgrasp batch``, ``dataset`` and ``eval`` run their jobs on."""

    name: str
    #: processes (local) or CPUs (Ray) working at once
    workers: int

    def run(
        self,
        fn: Callable[..., Any],
        jobs: Sequence[Job],
        on_done: OnDone,
        *,
        shared: Any = None,
        initializer: Callable[[], None] | None = None,
        on_crash: Callable[[int], None] | None = None,
    ) -> None:
        """``fn(*jobs[i])`` for every ``i``; ``on_done(i, result)`` in this
        process as each finishes (in any order). An error raised by ``fn``
        stops the run and is raised here."""
        ...

    def close(self) -> None:
        """Stop what the engine started (Ray's local instance)."""
        ...

    def __enter__(self) -> Engine: ...

    def __exit__(self, *exc: object) -> None: ...


class _Closing:
    """``with make_engine(...) as engine:`` closes it however the block ends."""

    def close(self) -> None:
        pass

    def __enter__(self) -> Any:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class LocalEngine(_Closing):
    """Jobs in this process (``workers`` 1, unless not ``in_process``) or in
    ``workers`` spawned processes of one BLAS/OpenMP thread each."""

    name = "local"

    def __init__(self, workers: int = 0, *, in_process: bool = True) -> None:
        self.workers = max(1, workers or (os.cpu_count() or 1))
        self.in_process = in_process

    def run(
        self,
        fn: Callable[..., Any],
        jobs: Sequence[Job],
        on_done: OnDone,
        *,
        shared: Any = None,
        initializer: Callable[[], None] | None = None,
        on_crash: Callable[[int], None] | None = None,
    ) -> None:
        from wsgrasp.sim._pool import run_in_processes

        workers = max(1, min(self.workers, len(jobs)))
        if workers == 1 and self.in_process:
            saved = dict(_SHARED)
            _set_shared(id(shared), shared)
            try:
                for i, job in enumerate(jobs):
                    on_done(i, fn(*job))
            finally:
                _SHARED.update(saved)
            return
        start = functools.partial(_start_process, shared, initializer)
        run_in_processes(
            fn, list(jobs), workers, on_done, initializer=start, on_crash=on_crash
        )


def _start_process(shared: Any, initializer: Callable[[], None] | None) -> None:
    """A pool process's start: the shared payload (pickled once per process)."""
    _set_shared("local", shared)
    if initializer is not None:
        initializer()


def require_ray() -> Any:
    """The ``ray`` module, or an ``InputError`` saying how to install it."""
    try:
        import ray
    except ImportError as exc:
        from wsgrasp.errors import InputError

        raise InputError(
            f"--engine ray needs Ray, which is not installed ({exc})",
            hint="pip install 'wsgrasp[ray]', or use --engine local",
        ) from None
    return ray


class RayEngine(_Closing):
    """Jobs as Ray tasks: a local Ray instance of ``workers`` CPUs started on
    first use (all cores with 0), or the cluster at ``address``.

    At most ``2 × workers`` tasks are in flight, so a long run holds few results
    in the object store; each result is handed over as soon as it is ready.
    """

    name = "ray"

    def __init__(self, workers: int = 0, address: str | None = None) -> None:
        self.address = address
        self.workers = max(1, workers or (os.cpu_count() or 1))
        self._started = False

    def _init(self) -> Any:
        ray = require_ray()
        if not ray.is_initialized():
            env = {k: "1" for k in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS")}
            kwargs: dict[str, Any] = {
                "runtime_env": {"env_vars": {**env, "PYTHONWARNINGS": "ignore"}},
                "log_to_driver": False,
                "configure_logging": False,
            }
            if self.address is None:  # a new instance, never another's
                kwargs.update(num_cpus=self.workers, include_dashboard=False)
            ray.init(address=self.address or "local", **kwargs)
            self._started = True
            if self.address is not None:  # the cluster's CPUs
                self.workers = max(1, int(ray.cluster_resources().get("CPU", 1)))
        return ray

    def run(
        self,
        fn: Callable[..., Any],
        jobs: Sequence[Job],
        on_done: OnDone,
        *,
        shared: Any = None,
        initializer: Callable[[], None] | None = None,
        on_crash: Callable[[int], None] | None = None,
    ) -> None:
        ray = self._init()
        from ray.exceptions import RayTaskError, WorkerCrashedError

        remote = ray.remote(num_cpus=1, max_retries=RAY_MAX_RETRIES)(_ray_call)
        # a list, so that the task gets the reference, not the value: it is
        # fetched once per worker process, not once per task
        box = [ray.put(shared)]
        queue = list(range(len(jobs)))[::-1]  # popped from the end: in order
        pending: dict[Any, int] = {}
        limit = 2 * self.workers
        try:
            while queue or pending:
                while queue and len(pending) < limit:
                    i = queue.pop()
                    pending[remote.remote(fn, box, initializer, *jobs[i])] = i
                ready, _ = ray.wait(list(pending), num_returns=1)
                for ref in ready:
                    i = pending.pop(ref)
                    try:
                        result = ray.get(ref)
                    except WorkerCrashedError:
                        if on_crash is None:
                            raise
                        on_crash(i)
                        continue
                    except RayTaskError as exc:
                        raise _cause(exc) from None
                    on_done(i, result)
        except BaseException:
            for ref in pending:
                ray.cancel(ref, force=True)
            raise

    def close(self) -> None:
        if self._started:
            ray = require_ray()
            ray.shutdown()
            self._started = False


def _cause(exc: Any) -> BaseException:
    """The error a Ray task raised, as itself (a ``WsgraspError`` stays one)."""
    cause = getattr(exc, "cause", None)
    return cause if isinstance(cause, BaseException) else exc


def _ray_call(
    fn: Callable[..., Any],
    box: list[Any],
    initializer: Callable[[], None] | None,
    *job: Any,
) -> Any:
    """Inside a Ray worker: the shared payload fetched once per process, then
    the job."""
    ref = box[0]
    if _SHARED["key"] != ref.hex():
        import ray

        if initializer is not None:
            initializer()
        _set_shared(ref.hex(), ray.get(ref))
    return fn(*job)


def make_engine(kind: str, workers: int = 0, address: str | None = None) -> Engine:
    """The engine ``--engine kind`` names (``local`` or ``ray``)."""
    from wsgrasp.errors import InputError

    if kind == "local":
        if address is not None:
            raise InputError(
                "--address names a Ray cluster, but --engine is local",
                hint="pass --engine ray with --address",
            )
        return LocalEngine(workers)
    if kind == "ray":
        require_ray()
        return RayEngine(workers, address)
    raise InputError(
        f"--engine {kind!r} is unknown, expected one of {', '.join(ENGINES)}",
        hint="pass --engine local or --engine ray",
    )
