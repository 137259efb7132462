"""``wsgrasp batch --simulate``: ``wsgrasp eval``'s trials, one Parquet row each.

A job is eval's task (:func:`wsgrasp.sim.runner.run_task`: one object × trial,
every gripper × spec planned on the same views and executed in MuJoCo), run on
any engine; the driver turns each record into a row of the ``trials`` table as it
arrives, so ``--resume`` runs only the (object, trial) pairs that are missing.
The outcomes are the ones ``wsgrasp eval`` reports for the same seed.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from wsgrasp.batch.engine import Engine
from wsgrasp.batch.sink import PartSink, require_pyarrow

__all__ = ["TrialSummary", "run_trials", "trial_schema"]


def trial_schema() -> Any:
    """The ``trials`` table's ``pyarrow.Schema`` (docs/reference/parquet.md)."""
    pa = require_pyarrow()
    return pa.schema(
        [
            ("object", pa.string()),
            ("trial", pa.int32()),
            ("gripper", pa.string()),
            ("spec", pa.string()),
            ("outcome", pa.string()),
            ("found", pa.bool_()),
            ("T_world_ee", pa.list_(pa.float64(), 16)),
            ("joints_grasp", pa.map_(pa.string(), pa.float64())),
            ("approach_from", pa.string()),
            ("finger_targets", pa.string()),
            ("metrics", pa.map_(pa.string(), pa.float64())),
            ("drops", pa.int32()),
            ("object_height", pa.float64()),
            ("plan_ms", pa.float64()),
            ("scene_s", pa.float64()),
            ("exec_s", pa.float64()),
            ("hint", pa.string()),
            ("record", pa.string()),
        ]
    )


@dataclass
class TrialSummary:
    """What a simulated batch did (this run's trials; ``resumed`` were there)."""

    tasks: int = 0
    trials: int = 0
    successes: int = 0
    resumed: int = 0
    wall_s: float = 0.0
    outcomes: dict[str, int] = field(default_factory=dict)


def trial_row(rec: dict[str, Any]) -> dict[str, Any]:
    """An eval record as a row of :func:`trial_schema` (the numeric metrics)."""
    row = {k: rec.get(k) for k in trial_schema().names}
    T = rec.get("T_world_ee")
    row["T_world_ee"] = None if T is None else np.asarray(T).reshape(16).tolist()
    metrics = rec.get("metrics") or {}
    row["metrics"] = {  # booleans as 0/1; joints_closed (a mapping) left out
        k: float(v)
        for k, v in metrics.items()
        if isinstance(v, (bool, int, float, np.number))
    }
    return row


def run_trials(
    objects: Sequence[Any],
    entries: Sequence[Any],
    out: Path,
    engine: Engine,
    *,
    trials: int = 1,
    seed: int = 0,
    params: Any = None,
    resume: bool = False,
    record_dir: Path | None = None,
    row_group: int = 64,
    progress: bool = True,
) -> TrialSummary:
    """Every object × trial with every spec entry on ``engine``; rows to
    ``out/trials``."""
    from wsgrasp.sim._mujoco import require_mujoco
    from wsgrasp.sim._pool import progress_bar
    from wsgrasp.sim.params import SimParams
    from wsgrasp.sim.runner import Task, _crashed, _init_worker, run_task

    require_mujoco()
    p = params if params is not None else SimParams()
    sink = PartSink(
        out,
        {"trials": trial_schema()},
        "trials",
        ("object", "trial"),
        resume=resume,
        row_group=row_group,
    )
    every = [(obj, t) for obj in objects for t in range(trials)]
    rec = str(record_dir) if record_dir else None
    tasks = [
        Task(every[i][0], every[i][1], seed, list(entries), p, rec)
        for i in sink.missing([(o.name, t) for o, t in every])
    ]
    summary = TrialSummary(resumed=len(every) - len(tasks))
    start = time.perf_counter()
    with progress_bar(progress and bool(tasks), "trials", len(tasks)) as advance:

        def done(i: int, records: list[dict[str, Any]]) -> None:
            sink.add({"trials": [trial_row(r) for r in records]})
            summary.tasks += 1
            for r in records:
                summary.trials += 1
                summary.successes += r["outcome"] == "success"
                o = r["outcome"]
                summary.outcomes[o] = summary.outcomes.get(o, 0) + 1
            advance(f"{summary.successes}/{summary.trials} held")

        try:
            engine.run(
                run_task,
                [(t,) for t in tasks],
                done,
                initializer=_init_worker,
                on_crash=lambda i: done(i, _crashed(tasks[i])),
            )
        finally:
            sink.flush()
    summary.wall_s = time.perf_counter() - start
    return summary
