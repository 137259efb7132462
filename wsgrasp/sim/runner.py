"""Running many trials: tasks, seeds, worker processes, the progress bar.

A *task* is one (object, trial index): the object is dropped and rendered once,
then every gripper × spec plans on the same views and executes its grasp, so the
grippers and specs are compared on identical scenes, with the same execution
error (:func:`wsgrasp.sim.trial.execution_error`, drawn from the task's seed).
Two specs that plan the same pose share one execution (MuJoCo is deterministic).
With a baseline (``EvalConfig.baseline``), each plan's choice is executed beside
``baseline`` uniformly random feasible candidates of the same plan, each
finished as the choice is (``Pipeline.plan_and_choices``: the plan that takes
it), so chance is measured on the same scene. Tasks run in worker processes
(``concurrent.futures.ProcessPoolExecutor``, spawned, one thread each); each worker
keeps its pipelines, grippers and compiled MuJoCo models between tasks.
"""

from __future__ import annotations

import os
import re
import time
import zlib
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from wsgrasp._names import gripper_label
from wsgrasp.sim._pool import progress_bar
from wsgrasp.sim.objects import SimObject
from wsgrasp.sim.params import SimParams

if TYPE_CHECKING:
    from wsgrasp.batch.engine import Engine

__all__ = [
    "BASELINE_DRAWS",
    "EvalConfig",
    "SpecEntry",
    "Task",
    "random_candidates",
    "run_eval",
    "run_task",
    "task_seed",
]

#: a random draw whose plan finds no grasp (its pre-grasp pose hits the table, as
#: the plan's own choice may not) is drawn again, up to this many draws per
#: candidate wanted
BASELINE_DRAWS = 4
#: the entry appended to a task's seed sequence for its random candidates
BASELINE_STREAM = 2


@dataclass(frozen=True)
class SpecEntry:
    """A pipeline spec to evaluate for one gripper: a label and the spec's data."""

    gripper: str
    label: str
    spec: dict[str, Any]
    source: str = ""


@dataclass
class EvalConfig:
    """What to evaluate: objects × trials, each with every spec entry."""

    objects: list[SimObject]
    specs: list[SpecEntry]
    trials: int = 10
    seed: int = 0
    params: SimParams = field(default_factory=SimParams)
    workers: int = 0
    record_dir: Path | None = None
    #: random feasible candidates executed beside each plan's choice (0: none)
    baseline: int = 0
    #: where each executed grasp's trial is drawn step by step (None: nowhere)
    film_dir: Path | None = None


@dataclass
class Task:
    object: SimObject
    trial: int
    seed: int
    specs: list[SpecEntry]
    params: SimParams
    record_dir: str | None = None
    baseline: int = 0
    film_dir: str | None = None


def task_seed(seed: int, object_name: str, trial: int) -> list[int]:
    """The seed sequence of one trial: stable across runs, object order and
    processes."""
    return [int(seed), zlib.crc32(object_name.encode()), int(trial)]


# --------------------------------------------------------------------------------
# inside a worker
# --------------------------------------------------------------------------------
_CACHE: dict[Any, Any] = {}
#: kinds of cache key ``(kind, object key, ...)`` that hold one object's MuJoCo
#: worlds: tasks come object after object, so a worker keeps one object's worlds
#: at a time (it kept every world it built: 12 GB after 650 tasks of 297 objects)
_WORLDS = ("bare", "scene")


def _cached(key: tuple[Any, ...], make: Callable[[], Any]) -> Any:
    """A worker's cache of pipelines, grippers and worlds (keys are tuples whose
    first item names the kind)."""
    if key[0] in _WORLDS:
        for k in [k for k in _CACHE if k[0] in _WORLDS and k[1] != key[1]]:
            del _CACHE[k]
    if key not in _CACHE:
        _CACHE[key] = make()
    return _CACHE[key]


def _pipeline(entry: SpecEntry) -> Any:
    from wsgrasp.api import Pipeline
    from wsgrasp.spec import load_spec

    key = ("pipeline", entry.gripper, entry.label, repr(sorted(entry.spec.items())))
    return _cached(key, lambda: Pipeline(load_spec(entry.spec)))


def _object_key(obj: SimObject) -> tuple[str, float, float | None, int]:
    return (obj.name, obj.mass, obj.friction, len(obj.parts))


def run_task(task: Task) -> list[dict[str, Any]]:
    """One (object, trial) with every spec; returns one record per spec (and,
    with a baseline, one per random candidate executed beside it)."""
    from wsgrasp.perception.io import scene_from_arrays
    from wsgrasp.sim.scene import build_scene
    from wsgrasp.sim.trial import render_views, settle_object

    p = task.params
    obj = task.object
    okey = _object_key(obj)
    rng = np.random.default_rng(task_seed(task.seed, obj.name, task.trial))
    bare = _cached(("bare", okey, p), lambda: build_scene(obj, None, p))
    t0 = time.perf_counter()
    settled = settle_object(bare, obj, rng, p)
    views = render_views(obj, settled.T_world_object, rng, p)
    scene = scene_from_arrays([(v.points, v.T_world_camera) for v in views])
    prep_s = time.perf_counter() - t0
    records: list[dict[str, Any]] = []
    # each distinct execution once: (Execution, its film PNG or None) by key
    executed: dict[tuple[str, bytes], Any] = {}
    recorders: list[Any] = []
    try:
        _run_specs(task, scene, prep_s, settled, records, executed, recorders)
    finally:
        for r in recorders:  # finished while the grasps were simulated
            r.close()
    return records


def record_name(gripper: str, label: str, object_name: str, trial: int) -> str:
    """The file name of one plan's recording in ``--record-dir``: the gripper
    (a YAML path by its file's stem), the spec's label, the object and the trial,
    with anything but letters, digits, ``.``, ``_`` and ``-`` made ``_``, so that
    every recording lands in the folder whatever the gripper or label is."""
    name = f"{gripper_label(gripper)}-{label}-{object_name}-{trial:03d}"
    return re.sub(r"[^A-Za-z0-9._-]", "_", name) + ".mcap"


def random_candidates(result: Any, rng: np.random.Generator, count: int) -> list[int]:
    """``count`` × :data:`BASELINE_DRAWS` feasible candidates of ``result``
    (indices into ``result.candidates``), drawn uniformly with replacement, in
    the order drawn; none when the plan has no feasible candidate."""
    feasible = np.flatnonzero(result.candidates.reason == 0)  # (F,) indices
    if count <= 0 or len(feasible) == 0:
        return []
    return [int(i) for i in rng.choice(feasible, size=BASELINE_DRAWS * count)]


def _plans(
    task: Task, entry: SpecEntry, scene: Any, observers: list[Any]
) -> tuple[Any, list[tuple[int, Any]]]:
    """The plan of ``entry`` and, with a baseline, the plans that take random
    feasible candidates of it (candidate index, plan), in the order drawn."""
    pipeline = _pipeline(entry)
    if task.baseline <= 0:
        return pipeline.plan(scene, observers=observers), []
    # the draws depend on the task, the gripper's name and the spec's label
    # only, so every protocol draws the same candidates of the same plan, and a
    # gripper YAML draws the same wherever its folder lies
    rng = np.random.default_rng(
        [
            *task_seed(task.seed, task.object.name, task.trial),
            BASELINE_STREAM,
            zlib.crc32(f"{pipeline.gripper.name}|{entry.label}".encode()),
        ]
    )
    drawn: list[int] = []

    def pick(result: Any) -> list[int]:
        drawn.extend(random_candidates(result, rng, task.baseline))
        return list(dict.fromkeys(drawn))  # each distinct candidate once

    result, taken = pipeline.plan_and_choices(scene, pick, observers=observers)
    by_index = dict(zip(dict.fromkeys(drawn), taken, strict=True))
    return result, [(i, by_index[i]) for i in drawn]


def _height(obj: SimObject, T_world_object: Any) -> float:
    """How high (m) the object stands on the table as it settled: its surface's
    extent along the world's vertical (the table's normal)."""
    v = np.asarray(obj.mesh().vertices, dtype=np.float64)  # (n, 3) object frame
    T = np.asarray(T_world_object, dtype=np.float64)
    z = v @ T[2, :3] + T[2, 3]  # (n,) world heights
    return float(z.max() - z.min()) if len(z) else 0.0


def _run_specs(
    task: Task,
    scene: Any,
    prep_s: float,
    settled: Any,
    records: list[dict[str, Any]],
    executed: dict[tuple[str, bytes], Any],
    recorders: list[Any],
) -> None:
    """The plans and grasps of one task, one record per spec and per random
    candidate (see :func:`run_task`)."""
    from wsgrasp.errors import WsgraspError
    from wsgrasp.sim.trial import execution_error

    p = task.params
    obj = task.object
    error = execution_error(task_seed(task.seed, obj.name, task.trial), p)
    for entry in task.specs:
        rec: dict[str, Any] = {
            "object": obj.name,
            "trial": task.trial,
            "gripper": entry.gripper,
            "spec": entry.label,
            "pick": "plan",
            "protocol": p.protocol,
            "drops": settled.drops,
            "object_height": _height(obj, settled.T_world_object),
            "scene_s": prep_s,
        }
        observers = []
        if task.record_dir:
            from wsgrasp.record import RunRecorder

            path = Path(task.record_dir) / record_name(
                entry.gripper, entry.label, obj.name, task.trial
            )
            observers.append(RunRecorder(path, force=True))
            recorders.append(observers[-1])
            rec["record"] = str(path)
        try:
            result, draws = _plans(task, entry, scene, observers)
        except WsgraspError as exc:
            rec.update(outcome="no_grasp", found=False, plan_ms=None, hint=str(exc))
            records.append(rec)
            records.extend(_random_records(task, rec, [], executed, settled, error))
            continue
        rec["plan_ms"] = float(result.timing_ms.get("total", float("nan")))
        _execute(task, entry, result, rec, executed, settled, error)
        records.append(rec)
        records.extend(_random_records(task, rec, draws, executed, settled, error))


def _random_records(
    task: Task,
    chosen: dict[str, Any],
    draws: list[tuple[int, Any]],
    executed: dict[tuple[str, bytes], Any],
    settled: Any,
    error: Any,
) -> list[dict[str, Any]]:
    """The baseline's records beside the plan's record ``chosen``: the first
    ``task.baseline`` draws whose plans found a grasp, executed as the choice
    is; draws short of that (no feasible candidate, every pre-grasp pose in the
    table) are ``no_grasp``."""
    if task.baseline <= 0:
        return []
    entry = next(
        e
        for e in task.specs
        if e.gripper == chosen["gripper"] and e.label == chosen["spec"]
    )
    base = {
        k: chosen[k]
        for k in (
            "object",
            "trial",
            "gripper",
            "spec",
            "protocol",
            "drops",
            "object_height",
            "scene_s",
        )
    }
    found = [
        (i, plan) for i, plan in draws if plan.found and plan.T_world_ee is not None
    ]
    out = []
    for k in range(task.baseline):
        rec = {**base, "pick": "random", "draw": k}
        if k < len(found):
            index, plan = found[k]
            rec.update(candidate=index, plan_ms=chosen.get("plan_ms"))
            _execute(task, entry, plan, rec, executed, settled, error)
        else:
            rec.update(
                outcome="no_grasp",
                found=False,
                plan_ms=None,
                hint="no feasible candidate whose plan finds a grasp was drawn",
            )
        out.append(rec)
    return out


def _execute(
    task: Task,
    entry: SpecEntry,
    result: Any,
    rec: dict[str, Any],
    executed: dict[tuple[str, bytes], Any],
    settled: Any,
    error: Any,
) -> None:
    """Execute the plan ``result`` (the choice of a plan, or a plan that takes
    another candidate: the same path) and fill in ``rec``."""
    from wsgrasp.sim.gripper import load_sim_gripper
    from wsgrasp.sim.scene import build_scene
    from wsgrasp.sim.trial import execute_grasp

    p = task.params
    obj = task.object
    okey = _object_key(obj)
    rec["found"] = bool(result.found)
    if not result.found or result.T_world_ee is None:
        rec.update(outcome="no_grasp", hint=result.hint)
        return
    T = np.asarray(result.T_world_ee, dtype=np.float64)
    # the plan's per-grasp targets; a plan without them approaches from the
    # standoff and closes towards the gripper YAML's `closed` posture
    T_pre = result.T_world_pregrasp
    T_pre = None if T_pre is None else np.asarray(T_pre, dtype=np.float64)
    joints_pre = dict(result.joints_pregrasp)
    joints_grasp = dict(result.joints_grasp)
    rec["approach_from"] = "standoff" if T_pre is None else "plan"
    rec["finger_targets"] = "plan" if joints_grasp else "closed"
    # one execution per distinct (pose, pre-grasp pose, joint targets)
    key = (
        entry.gripper,
        b"|".join(
            [
                np.round(T, 9).tobytes(),
                b"" if T_pre is None else np.round(T_pre, 9).tobytes(),
                _joints_key(joints_pre),
                _joints_key(joints_grasp),
            ]
        ),
    )
    t1 = time.perf_counter()
    if key not in executed:
        sim_gripper = _cached(
            ("gripper", entry.gripper, p),
            lambda: load_sim_gripper(entry.gripper, p),
        )
        world = _cached(
            ("scene", okey, entry.gripper, p),
            lambda: build_scene(obj, sim_gripper, p),
        )
        c0 = time.process_time()
        ex = execute_grasp(
            world,
            settled.T_world_object,
            T,
            p,
            T_world_pregrasp=T_pre,
            joints_pregrasp=joints_pre,
            joints_grasp=joints_grasp,
            error=error,
            film=task.film_dir is not None,
        )
        ex.metrics["cpu_s"] = time.process_time() - c0
        # with its film, drawn once and named by every record of it
        film = None if task.film_dir is None else _draw_film(task, entry, rec, ex)
        executed[key] = (ex, film)
    ex, film = executed[key]
    if film is not None:
        rec["film"] = film
    rec.update(
        outcome=ex.outcome,
        metrics=ex.metrics,
        exec_s=time.perf_counter() - t1,
        T_world_ee=T.tolist(),
        execution_error=error.to_json(),
    )
    if joints_grasp:
        rec["joints_grasp"] = joints_grasp


def _draw_film(task: Task, entry: SpecEntry, rec: dict[str, Any], ex: Any) -> str:
    """Draw a filmed execution into ``task.film_dir``, named as its plan's
    recording is (a random pick with its draw); returns the file's path."""
    from wsgrasp.sim.film import draw_film

    name = record_name(entry.gripper, entry.label, task.object.name, task.trial)
    stem = name[: -len(".mcap")]
    if rec.get("pick") == "random":
        stem += f"-random{rec.get('draw', 0)}"
    path = Path(str(task.film_dir)) / f"{stem}.png"
    draw_film(
        ex.film,
        path,
        title=f"{gripper_label(entry.gripper)} ({entry.label}) on {task.object.name}, "
        f"trial {task.trial}: {ex.outcome}",
    )
    return str(path)


def _joints_key(joints: dict[str, float]) -> bytes:
    """Joint targets as bytes for the execution cache (names sorted, values
    rounded like the poses)."""
    return repr(sorted((k, round(float(v), 9)) for k, v in joints.items())).encode()


def _init_worker() -> None:
    import warnings

    warnings.filterwarnings("ignore")


# --------------------------------------------------------------------------------
# the parent
# --------------------------------------------------------------------------------
def run_eval(
    config: EvalConfig,
    *,
    progress: bool = True,
    on_record: Callable[[dict[str, Any]], None] | None = None,
    engine: Engine | None = None,
) -> tuple[list[dict[str, Any]], float]:
    """Run every task of ``config``; returns the trial records (in task order) and
    the wall-clock seconds.

    ``workers`` 0 means one per CPU core; 1 runs in this process (no pool).
    ``engine`` (:mod:`wsgrasp.batch.engine`, e.g. Ray) runs the tasks instead
    of the local pool; the records are the same, trial for trial.
    """
    from wsgrasp.batch.engine import LocalEngine
    from wsgrasp.sim._mujoco import require_mujoco

    require_mujoco()
    tasks = [
        Task(
            object=obj,
            trial=t,
            seed=config.seed,
            specs=config.specs,
            params=config.params,
            record_dir=str(config.record_dir) if config.record_dir else None,
            baseline=config.baseline,
            film_dir=str(config.film_dir) if config.film_dir else None,
        )
        for obj in config.objects
        for t in range(config.trials)
    ]
    workers = config.workers or (os.cpu_count() or 1)
    workers = max(1, min(workers, len(tasks)))
    start = time.perf_counter()
    results: list[list[dict[str, Any]] | None] = [None] * len(tasks)
    tally = _Tally()

    with progress_bar(progress, "trials", len(tasks)) as advance:

        def done(i: int, recs: list[dict[str, Any]]) -> None:
            results[i] = recs
            _emit(recs, on_record)
            advance(tally.add(recs))

        # this process with 1 worker, else a pool of spawned processes or Ray
        eng = engine if engine is not None else LocalEngine(workers)
        eng.run(
            run_task,
            [(t,) for t in tasks],
            done,
            initializer=_init_worker,
            on_crash=lambda i: done(i, _crashed(tasks[i])),
        )
    wall = time.perf_counter() - start
    return [r for rs in results for r in (rs or [])], wall


def _crashed(task: Task) -> list[dict[str, Any]]:
    """The records of a task whose process died twice (MuJoCo or the system
    killed it): one ``sim_crashed`` record per spec, so the report counts it."""
    return [
        {
            "object": task.object.name,
            "trial": task.trial,
            "gripper": e.gripper,
            "spec": e.label,
            "pick": "plan",
            "protocol": task.params.protocol,
            "outcome": "sim_crashed",
            "found": None,
            "plan_ms": None,
            "hint": "the worker process running this trial died twice",
        }
        for e in task.specs
    ]


def _emit(
    records: Sequence[dict[str, Any]] | None,
    on_record: Callable[[dict[str, Any]], None] | None,
) -> None:
    if on_record is not None and records:
        for r in records:
            on_record(r)


class _Tally:
    """Grasps held so far, as the progress bar's status."""

    def __init__(self) -> None:
        self.successes = 0
        self.trials = 0

    def add(self, records: list[dict[str, Any]]) -> str:
        records = [r for r in records if r.get("pick", "plan") == "plan"]
        self.trials += len(records)
        self.successes += sum(r.get("outcome") == "success" for r in records)
        last = records[0]["object"] if records else ""
        return f"{self.successes}/{self.trials} grasps held · {last}"
