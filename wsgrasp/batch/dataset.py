"""``wsgrasp dataset``: grasp candidates with simulated success labels.

A job is one (object, trial): the object is dropped with the trial's seed (the
same seed sequence as ``wsgrasp eval``'s trial, :func:`wsgrasp.sim.runner.
task_seed`, so the same drop and views), seen in three noisy depth views, and
planned on; every feasible candidate is a row of the ``candidates`` table with
its score terms, and the ``top_k`` best by score are executed in MuJoCo for a
label. Each is executed as ``wsgrasp eval`` executes a plan's choice, under the
same protocol (``params``; strict by default) and execution error: the plan
with that candidate taken as the choice (``Pipeline.plan_and_choices``, as
``Pipeline.plan(..., choose=)`` gives it, from the plan's own search: its
table back-off, pre-grasp pose and joint targets), so a label says whether the
grasp holds when the planner picks it. ``label_targets`` is "plan" where that
plan has per-finger joint targets and "closed" where the gripper model keeps no
finger configurations (the fingers close to the gripper's ``closed`` posture).
A candidate whose pre-grasp pose would hit the table is labelled
``no_grasp``, as the plan that took it would find none. The ``scenes`` table
has one row per job: the settled pose, the views (points in camera frames) and
the counts.

Chance beside the choice: ``random_k`` uniformly random feasible candidates of
each scene (drawn without replacement with a seed of the trial's, the same for
every run) are labelled too, finished exactly as the top ones are, and marked
``random_pick``; a scene's ``chosen_success`` and ``random_successes`` /
``random_labels`` give the choice's outcome beside chance's on the same drop.
"""

from __future__ import annotations

import os
import socket
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from wsgrasp.batch.engine import Engine, shared
from wsgrasp.batch.sink import PartSink, require_pyarrow

__all__ = ["DatasetSummary", "dataset_schemas", "run_dataset"]


def dataset_schemas() -> dict[str, Any]:
    """The ``candidates`` and ``scenes`` tables' schemas
    (docs/reference/parquet.md)."""
    pa = require_pyarrow()
    pose = pa.list_(pa.float64(), 16)  # (4, 4) row-major
    floats = pa.map_(pa.string(), pa.float64())
    candidates = pa.schema(
        [
            ("object", pa.string()),
            ("trial", pa.int32()),
            ("candidate", pa.int32()),
            ("rank", pa.int32()),
            ("score", pa.float64()),
            ("score_terms", floats),
            ("T_world_ee", pose),
            ("T_world_gwc", pose),
            ("sample", pa.int32()),
            ("orientation", pa.int32()),
            ("theta", pa.float64()),
            ("flipped", pa.bool_()),
            ("contacts", pa.list_(pa.int32())),
            ("chosen", pa.bool_()),
            ("random_pick", pa.bool_()),
            ("label", pa.string()),
            ("success", pa.bool_()),
            ("friction_use", pa.float64()),
            ("label_targets", pa.string()),
            ("gripper", pa.string()),
        ]
    )
    view = pa.struct(
        [
            ("T_world_camera", pose),
            ("points", pa.list_(pa.float32())),  # (n, 3) camera frame, flattened
        ]
    )
    scenes = pa.schema(
        [
            ("object", pa.string()),
            ("trial", pa.int32()),
            ("seed", pa.list_(pa.int64())),
            ("mass", pa.float64()),
            ("friction", pa.float64()),
            ("T_world_object", pose),
            ("drops", pa.int32()),
            ("found", pa.bool_()),
            ("best_candidate", pa.int32()),
            ("candidates", pa.int32()),
            ("feasible", pa.int32()),
            ("labels", pa.int32()),
            ("successes", pa.int32()),
            ("chosen_success", pa.bool_()),
            ("random_labels", pa.int32()),
            ("random_successes", pa.int32()),
            ("error", pa.string()),
            ("scene_s", pa.float64()),
            ("plan_ms", pa.float64()),
            ("sim_s", pa.float64()),
            ("cpu_s", pa.float64()),
            ("views", pa.list_(view)),
            ("gripper", pa.string()),
            ("spec_hash", pa.string()),
            ("wsgrasp_version", pa.string()),
            ("worker", pa.string()),
        ]
    )
    return {"candidates": candidates, "scenes": scenes}


@dataclass
class DatasetSummary:
    """What a dataset run did (this run's scenes; ``resumed`` were there)."""

    scenes: int = 0
    resumed: int = 0
    candidates: int = 0
    labels: int = 0
    successes: int = 0
    #: scenes whose choice was labelled, and of them those it held
    chosen: int = 0
    chosen_successes: int = 0
    #: random feasible candidates labelled, and of them those that held
    random_labels: int = 0
    random_successes: int = 0
    errors: int = 0
    wall_s: float = 0.0

    @property
    def labels_per_hour(self) -> float:
        return 3600.0 * self.labels / self.wall_s if self.wall_s > 0 else 0.0

    def to_json(self) -> dict[str, Any]:
        return {
            "scenes": self.scenes,
            "resumed": self.resumed,
            "candidates": self.candidates,
            "labels": self.labels,
            "successes": self.successes,
            "chosen": self.chosen,
            "chosen_successes": self.chosen_successes,
            "random_labels": self.random_labels,
            "random_successes": self.random_successes,
            "errors": self.errors,
            "wall_s": round(self.wall_s, 1),
            "labels_per_hour": round(self.labels_per_hour, 1),
        }


def _flat(T: Any) -> list[float]:
    return np.asarray(T, dtype=np.float64).reshape(16).tolist()


# --------------------------------------------------------------------------------
# inside a worker
# --------------------------------------------------------------------------------
def dataset_job(obj: Any, trial: int) -> dict[str, list[dict[str, Any]]]:
    """One (object, trial): drop, views, plan, labels; rows of both tables."""
    from wsgrasp._version import __version__
    from wsgrasp.api import Pipeline
    from wsgrasp.errors import WsgraspError
    from wsgrasp.perception.io import scene_from_arrays
    from wsgrasp.sim.objects import trial_friction, trial_mass
    from wsgrasp.sim.runner import _cached, _object_key, task_seed
    from wsgrasp.sim.scene import build_scene
    from wsgrasp.sim.trial import render_views, settle_object

    pay = shared()
    p = pay["params"]
    seed = task_seed(pay["seed"], obj.name, trial)
    rng = np.random.default_rng(seed)
    okey = _object_key(obj)
    t0, cpu0 = time.perf_counter(), time.process_time()
    bare = _cached(("bare", okey, p), lambda: build_scene(obj, None, p))
    settled = settle_object(bare, obj, rng, p)
    views = render_views(obj, settled.T_world_object, rng, p)
    cloud = scene_from_arrays([(v.points, v.T_world_camera) for v in views])
    scene_row: dict[str, Any] = {
        "object": obj.name,
        "trial": trial,
        "seed": seed,
        "mass": trial_mass(obj, p),
        "friction": trial_friction(obj, p),
        "T_world_object": _flat(settled.T_world_object),
        "drops": settled.drops,
        "found": False,
        "scene_s": time.perf_counter() - t0,
        "views": [
            {
                "T_world_camera": _flat(v.T_world_camera),
                "points": np.asarray(v.points, dtype=np.float32).reshape(-1),
            }
            for v in (views if pay["views"] else [])
        ],
        "gripper": pay["gripper"],
        "spec_hash": pay["spec_hash"],
        "wsgrasp_version": __version__,
        "worker": f"{socket.gethostname()}:{os.getpid()}",
    }
    key = ("pipeline", id(pay))
    pipeline = _cached(key, lambda: Pipeline(pay["spec"], gripper=pay["model"]))
    top_k = int(pay["top_k"])
    random_k = int(pay.get("random_k", 0))
    drawn: list[int] = []

    def others(res: Any) -> list[int]:
        """The labelled candidates besides the plan's choice: the top ones, then
        the random draws that are not among them."""
        chosen = res.best_index if res.found else -1
        top = [int(c) for c in _ranked(res.candidates)[:top_k]]
        drawn.extend(random_feasible(res.candidates, seed, random_k))
        extra = [c for c in drawn if c not in top]
        return [c for c in top + extra if c != chosen]

    try:
        # the plan and the plans that take its other labelled candidates, from
        # one search of the scene
        result, taken_plans = pipeline.plan_and_choices(cloud, others)
    except WsgraspError as exc:
        scene_row["error"] = f"{type(exc).__name__}: {exc}"
        scene_row["cpu_s"] = time.process_time() - cpu0
        return {"candidates": [], "scenes": [scene_row]}
    rows = _candidate_rows(result, obj.name, trial, pay["gripper"])
    t1 = time.perf_counter()
    by_candidate = {r["candidate"]: r for r in rows}
    picked = set(drawn)
    for r in rows:
        r["random_pick"] = r["candidate"] in picked
    # in the order others() gave the plans: the top rows, then the draws
    top = [int(r["candidate"]) for r in rows[:top_k]]
    order = top + [c for c in drawn if c not in top]
    others_taken = iter(taken_plans)
    for c in order:
        row = by_candidate[c]
        taken = result if row["chosen"] else next(others_taken)
        outcome, use = _label(row, taken, obj, settled, okey, pay, seed)
        row.update(label=outcome, success=outcome == "success", friction_use=use)
    chosen_row = next((r for r in rows if r["chosen"]), None)
    random_rows = [by_candidate[c] for c in drawn]
    scene_row.update(
        chosen_success=None
        if chosen_row is None or "success" not in chosen_row
        else bool(chosen_row["success"]),
        random_labels=len(random_rows),
        random_successes=sum(bool(r["success"]) for r in random_rows),
    )
    scene_row.update(
        found=bool(result.found),
        best_candidate=result.best_index,
        candidates=len(result.candidates),
        feasible=len(rows),
        labels=len(order),
        successes=sum(bool(r.get("success")) for r in rows),
        plan_ms=float(result.timing_ms.get("total", float("nan"))),
        sim_s=time.perf_counter() - t1,
        cpu_s=time.process_time() - cpu0,
    )
    return {"candidates": rows, "scenes": [scene_row]}


def _candidate_rows(
    result: Any, name: str, trial: int, gripper: str
) -> list[dict[str, Any]]:
    """Every feasible candidate, best score first (rank 0)."""
    C = result.candidates
    order = _ranked(C)
    # (F, 16) row-major poses, of the feasible candidates alone
    ee = C.ee_at(order).reshape(-1, 16)
    gwc = C.gwc_at(order).reshape(-1, 16)
    terms = {k: np.asarray(v)[order] for k, v in C.terms.items()}
    return [
        {
            "object": name,
            "trial": trial,
            "candidate": int(c),
            "rank": r,
            "score": float(C.score[c]),
            "score_terms": {k: float(v[r]) for k, v in terms.items()},
            "T_world_ee": ee[r].tolist(),
            "T_world_gwc": gwc[r].tolist(),
            "sample": int(C.sample[c]),
            "orientation": int(C.orientation[c]),
            "theta": float(C.theta[c]),
            "flipped": bool(C.flipped[c]),
            "contacts": C.contacts[c].tolist(),
            "chosen": bool(result.found and c == result.best_index),
            "gripper": gripper,
        }
        for r, c in enumerate(order)
    ]


def random_feasible(C: Any, seed: Sequence[int], count: int) -> list[int]:
    """``count`` feasible candidates of ``C`` (all of them if fewer), drawn
    uniformly without replacement, in the order drawn; the draw depends on the
    trial's ``seed`` alone, so every run of the same trial draws the same."""
    feasible = np.flatnonzero(C.reason == 0)  # (F,) candidate indices
    if count <= 0 or len(feasible) == 0:
        return []
    rng = np.random.default_rng([*seed, RANDOM_STREAM])
    picks = rng.choice(feasible, size=min(count, len(feasible)), replace=False)
    return [int(c) for c in picks]


#: the seed sequence's extra entry of the random labels' draws (apart from the
#: drop's, the views' and the execution error's streams)
RANDOM_STREAM = 3


def _ranked(C: Any) -> NDArray[np.int64]:
    """Indices of the feasible candidates, best score first (ties in index
    order)."""
    feasible = np.flatnonzero(C.reason == 0)  # (F,) candidate indices
    return feasible[np.argsort(-C.score[feasible], kind="stable")]


def _label(
    row: dict[str, Any],
    taken: Any,
    obj: Any,
    settled: Any,
    okey: Any,
    pay: dict[str, Any],
    seed: list[int],
) -> tuple[str, float | None]:
    """Execute the plan ``taken`` (one candidate as the choice) in MuJoCo, with
    the trial's execution error (the one ``wsgrasp eval`` gives the same trial);
    its outcome and, for a grasp that held, how near the grip came to sliding
    at the end of the hold (the trial's ``friction_use_held``)."""
    from wsgrasp.sim.gripper import load_sim_gripper
    from wsgrasp.sim.runner import _cached
    from wsgrasp.sim.scene import build_scene
    from wsgrasp.sim.trial import execute_grasp, execution_error

    row["label_targets"] = "plan" if taken.joints_grasp else "closed"
    if not taken.found or taken.T_world_ee is None:
        return "no_grasp", None
    p, g = pay["params"], pay["gripper"]
    sim_gripper = _cached(("gripper", g, p), lambda: load_sim_gripper(g, p))
    world = _cached(("scene", okey, g, p), lambda: build_scene(obj, sim_gripper, p))
    pre = taken.T_world_pregrasp
    ex = execute_grasp(
        world,
        settled.T_world_object,
        np.asarray(taken.T_world_ee, dtype=np.float64),
        p,
        T_world_pregrasp=None if pre is None else np.asarray(pre, np.float64),
        joints_pregrasp=dict(taken.joints_pregrasp),
        joints_grasp=dict(taken.joints_grasp),
        error=execution_error(seed, p),
    )
    use = ex.metrics.get("friction_use_held") if ex.outcome == "success" else None
    return str(ex.outcome), None if use is None else float(use)


# --------------------------------------------------------------------------------
# the parent
# --------------------------------------------------------------------------------
def run_dataset(
    objects: Sequence[Any],
    spec: Any,
    gripper: str,
    out: Path,
    engine: Engine,
    *,
    trials: int = 1,
    top_k: int = 5,
    random_k: int = 0,
    seed: int = 0,
    params: Any = None,
    resume: bool = False,
    views: bool = True,
    row_group: int = 8,
    progress: bool = True,
    on_scene: Callable[[dict[str, Any]], None] | None = None,
) -> DatasetSummary:
    """Every object × trial on ``engine``; tables ``out/candidates`` and
    ``out/scenes``, written as jobs finish (``resume`` skips the scenes there).
    Without ``views`` the scenes' rows hold no points (~1.7 MB a scene less).
    ``random_k`` random feasible candidates of each scene are labelled beside
    the top ``top_k`` (chance, :func:`random_feasible`)."""
    from wsgrasp._names import gripper_ref
    from wsgrasp.batch.plans import spec_hash
    from wsgrasp.gripper import load_gripper
    from wsgrasp.sim._mujoco import require_mujoco
    from wsgrasp.sim._pool import progress_bar
    from wsgrasp.sim.params import SimParams

    require_mujoco()
    base = spec.source.parent if spec.source is not None else Path.cwd()
    payload = {
        "spec": spec,
        "model": load_gripper(gripper_ref(spec.gripper, base)),  # built once
        "gripper": gripper,
        "spec_hash": spec_hash(spec),
        "params": params if params is not None else SimParams(),
        "seed": seed,
        "top_k": top_k,
        "random_k": random_k,
        "views": views,
    }
    sink = PartSink(
        out,
        dataset_schemas(),
        "scenes",
        ("object", "trial"),
        resume=resume,
        row_group=row_group,
    )
    every = [(obj, t) for obj in objects for t in range(trials)]
    jobs = [every[i] for i in sink.missing([(o.name, t) for o, t in every])]
    summary = DatasetSummary(resumed=len(every) - len(jobs))
    start = time.perf_counter()
    with progress_bar(progress and bool(jobs), "scenes", len(jobs)) as advance:

        def done(i: int, rows: dict[str, list[dict[str, Any]]]) -> None:
            sink.add(rows)
            s = rows["scenes"][0]
            summary.scenes += 1
            summary.candidates += len(rows["candidates"])
            summary.labels += int(s.get("labels") or 0)
            summary.successes += int(s.get("successes") or 0)
            if s.get("chosen_success") is not None:
                summary.chosen += 1
                summary.chosen_successes += bool(s["chosen_success"])
            summary.random_labels += int(s.get("random_labels") or 0)
            summary.random_successes += int(s.get("random_successes") or 0)
            summary.errors += s.get("error") is not None
            advance(f"{summary.successes}/{summary.labels} held · {s['object']}")
            if on_scene is not None:
                on_scene(s)

        def crashed(i: int) -> None:
            obj, t = jobs[i]
            error = "WorkerCrashed: the process of this scene died every time"
            row = {"object": obj.name, "trial": t, "error": error, "gripper": gripper}
            done(i, {"candidates": [], "scenes": [row]})

        try:
            engine.run(dataset_job, jobs, done, shared=payload, on_crash=crashed)
        finally:
            sink.flush()
    summary.wall_s = time.perf_counter() - start
    return summary
