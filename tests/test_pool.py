"""The process pool the trials run in: a process that dies costs only its job."""

from __future__ import annotations

import os
import signal
from pathlib import Path

from wsgrasp.sim._pool import run_in_processes


def _job(i: int, marker: str) -> int:
    """Kills its own process when it is job 3, always, or job 5, the first time."""
    flag = Path(marker) / f"{i}"
    if i == 3 or (i == 5 and not flag.exists()):
        flag.touch()
        os.kill(os.getpid(), signal.SIGKILL)
    return i * i


def test_a_killed_worker_costs_only_its_job(tmp_path):
    done: dict[int, int] = {}
    crashed: list[int] = []
    jobs = [(i, str(tmp_path)) for i in range(8)]
    run_in_processes(
        _job, jobs, 2, lambda i, r: done.__setitem__(i, r), on_crash=crashed.append
    )
    # job 5 died once and was run again; job 3 died every time and is reported
    assert crashed == [3]
    assert done == {i: i * i for i in range(8) if i != 3}
