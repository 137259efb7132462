"""``wsgrasp batch``: every scene × spec planned, one Parquet row per plan.

Each scene is planned on its own (unlike ``wsgrasp plan``, where several files
are views of one scene): a cloud file, a scene YAML, or a folder of them. The
specs and their gripper models are built once in this process and shared with
the workers (:func:`wsgrasp.batch.engine.shared`); each worker builds one
``Pipeline`` per spec and keeps it. The rows (schema: :data:`PLAN_SCHEMA`, and
docs/reference/parquet.md) are written by this process as
results arrive (:class:`~wsgrasp.batch.sink.PartSink`), so ``--resume`` after a
crash plans only what is missing.
"""

from __future__ import annotations

import hashlib
import os
import socket
import time
from collections import Counter
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from wsgrasp.batch.engine import Engine, shared
from wsgrasp.batch.sink import PartSink, require_pyarrow
from wsgrasp.errors import InputError, WsgraspError

__all__ = [
    "BatchSpec",
    "BatchSummary",
    "plan_schema",
    "plan_chunk",
    "plan_job",
    "plan_row",
    "run_batch",
    "scene_paths",
]


@dataclass(frozen=True)
class BatchSpec:
    """One spec of a batch: its label (the ``spec`` column) and the loaded spec."""

    label: str
    spec: Any  # PipelineSpec


@dataclass
class BatchSummary:
    """What a batch run did.

    Attributes
    ----------
    planned : int
        Plans run (and written) now.
    resumed : int
        Plans found in the output folder and skipped.
    found : int
        Plans of this run with a grasp.
    wall_s : float
    failures : list of dict
        One entry per plan of this run without a grasp: scene, spec, reason.
    """

    planned: int = 0
    resumed: int = 0
    found: int = 0
    wall_s: float = 0.0
    failures: list[dict[str, str]] = field(default_factory=list)

    @property
    def plans_per_s(self) -> float:
        return self.planned / self.wall_s if self.wall_s > 0 else 0.0

    def failure_counts(self) -> list[tuple[str, str, int, str]]:
        """(spec, reason, count, first scene), most frequent first."""
        counts = Counter((f["spec"], f["reason"]) for f in self.failures)
        first: dict[tuple[str, str], str] = {}
        for f in self.failures:
            first.setdefault((f["spec"], f["reason"]), f["scene"])
        return [(s, r, n, first[(s, r)]) for (s, r), n in counts.most_common()]


def plan_schema() -> Any:
    """The ``plans`` table's ``pyarrow.Schema`` (docs/reference/parquet.md)."""
    pa = require_pyarrow()
    pose = pa.list_(pa.float64(), 16)  # (4, 4) row-major
    floats = pa.map_(pa.string(), pa.float64())
    return pa.schema(
        [
            ("scene", pa.string()),
            ("spec", pa.string()),
            ("gripper", pa.string()),
            ("found", pa.bool_()),
            ("score", pa.float64()),
            ("score_terms", floats),
            ("T_world_ee", pose),
            ("T_world_tcp", pose),
            ("T_world_pregrasp", pose),
            ("joints_pregrasp", floats),
            ("joints_grasp", floats),
            ("T_world_object", pose),
            ("candidates", pa.int32()),
            ("feasible", pa.int32()),
            ("rejections", pa.map_(pa.string(), pa.int32())),
            ("hint", pa.string()),
            ("warnings", pa.list_(pa.string())),
            ("error", pa.string()),
            ("plan_ms", pa.float64()),
            ("load_ms", pa.float64()),
            ("cpu_ms", pa.float64()),
            ("timing_ms", floats),
            ("record", pa.string()),
            ("spec_hash", pa.string()),
            ("wsgrasp_version", pa.string()),
            ("worker", pa.string()),
        ]
    )


def scene_paths(args: Sequence[str | Path]) -> list[Path]:
    """The scenes of ``batch``'s arguments, in order: a cloud file or scene YAML
    is one scene; a folder's scene YAMLs are its scenes, or, with none, each of
    its cloud files (sorted, not recursive)."""
    from wsgrasp.perception.depth import DEPTH_SUFFIXES
    from wsgrasp.perception.io import CLOUD_SUFFIXES, SCENE_SUFFIXES

    out: list[Path] = []
    for arg in args:
        p = Path(arg)
        if p.is_dir():
            files = sorted(f for f in p.iterdir() if f.is_file())
            yamls = [f for f in files if f.suffix.lower() in SCENE_SUFFIXES]
            clouds = [f for f in files if f.suffix.lower() in CLOUD_SUFFIXES]
            found = yamls or clouds
            if not found:
                images = any(f.suffix.lower() in DEPTH_SUFFIXES for f in files)
                raise InputError(
                    f"folder {p} holds no cloud file or scene YAML"
                    + (" (its depth images need their intrinsics)" if images else ""),
                    hint=f"put scenes ({', '.join(CLOUD_SUFFIXES)}, .yaml) in it"
                    + (
                        "; list each depth image in a scene YAML with its "
                        "`intrinsics:` (examples/scenes/README.md)"
                        if images
                        else ""
                    ),
                )
            out.extend(found)
        elif p.exists():
            out.append(p)
        else:
            raise InputError(
                f"scene {p} does not exist",
                hint="give cloud files, scene YAMLs or folders of them",
            )
    seen: set[str] = set()
    for p in out:
        if str(p) in seen:
            raise InputError(
                f"scene {p} is given twice",
                hint="give each scene once (its rows are keyed by its path)",
            )
        seen.add(str(p))
    return out


def spec_hash(spec: Any) -> str:
    """12 hex digits of the spec's content (its gripper included)."""
    text = spec.model_dump_json()
    return hashlib.sha256(text.encode()).hexdigest()[:12]


def _flat(T: Any) -> list[float] | None:
    return None if T is None else np.asarray(T, dtype=np.float64).reshape(16).tolist()


def plan_row(result: Any) -> dict[str, Any]:
    """The columns of a ``PlanResult`` in :func:`plan_schema`."""
    return {
        "gripper": result.gripper,
        "found": bool(result.found),
        "score": None if result.score is None else float(result.score),
        "score_terms": {k: float(v) for k, v in result.score_terms.items()},
        "T_world_ee": _flat(result.T_world_ee),
        "T_world_tcp": _flat(result.T_world_tcp),
        "T_world_pregrasp": _flat(result.T_world_pregrasp),
        "joints_pregrasp": {k: float(v) for k, v in result.joints_pregrasp.items()},
        "joints_grasp": {k: float(v) for k, v in result.joints_grasp.items()},
        "T_world_object": _flat(result.T_world_object),
        "candidates": len(result.candidates),
        "feasible": int(result.candidates.feasible.sum()),
        "rejections": {k: int(v) for k, v in result.rejections.items()},
        "hint": result.hint or None,
        "warnings": list(result.warnings),
        "plan_ms": float(result.timing_ms.get("total", float("nan"))),
        "timing_ms": {k: float(v) for k, v in result.timing_ms.items()},
    }


# --------------------------------------------------------------------------------
# inside a worker
# --------------------------------------------------------------------------------
_PIPELINES: dict[tuple[int, str], Any] = {}


def _pipeline(label: str) -> Any:
    """This worker's pipeline of spec ``label``, built once from the shared spec
    and gripper model."""
    from wsgrasp.api import Pipeline

    payload = shared()
    key = (id(payload), label)
    if key not in _PIPELINES:
        spec, gripper = payload["specs"][label]
        _PIPELINES[key] = Pipeline(spec, gripper=gripper)
    return _PIPELINES[key]


def plan_job(scene: str, label: str, record: str | None) -> dict[str, Any]:
    """Plan spec ``label`` on the scene file ``scene``; one row."""
    from wsgrasp._version import __version__
    from wsgrasp.perception.io import load_scene

    payload = shared()
    pipeline = _pipeline(label)
    row: dict[str, Any] = {
        "scene": scene,
        "spec": label,
        "gripper": pipeline.gripper.name,
        "found": False,
        "spec_hash": payload["hashes"][label],
        "wsgrasp_version": __version__,
        "worker": f"{socket.gethostname()}:{os.getpid()}",
    }
    observers = []
    if record is not None:
        from wsgrasp.record import RunRecorder

        observers.append(RunRecorder(Path(record), force=True))
    t0, cpu0 = time.perf_counter(), time.process_time()
    try:
        try:
            cloud = load_scene([scene], icp=pipeline.spec.preprocess.icp)
            row["load_ms"] = (time.perf_counter() - t0) * 1e3
            result = pipeline.plan(cloud, observers=observers)
        finally:
            for o in observers:
                o.close()
            row["cpu_ms"] = (time.process_time() - cpu0) * 1e3
            if observers:  # the file whole before its row says it is there
                from wsgrasp.record import wait_for_recorders

                wait_for_recorders()
    except (WsgraspError, OSError) as exc:
        row["error"] = f"{type(exc).__name__}: {exc}"
        return row
    row.update(plan_row(result))
    if record is not None:
        row["record"] = record
    return row


def plan_chunk(items: Sequence[tuple[str, str, str | None]]) -> list[dict[str, Any]]:
    """:func:`plan_job` for each ``(scene, label, record)``; their rows."""
    return [plan_job(*item) for item in items]


# --------------------------------------------------------------------------------
# the parent
# --------------------------------------------------------------------------------
def _slug(scene: str) -> str:
    """A file name for a scene's recording (its path with separators replaced)."""
    return scene.replace(os.sep, "__").replace("/", "__").lstrip(".") or "scene"


def run_batch(
    scenes: Sequence[Path],
    specs: Sequence[BatchSpec],
    out: Path,
    engine: Engine,
    *,
    resume: bool = False,
    record: bool = False,
    row_group: int = 64,
    chunk: int = 8,
    progress: bool = True,
    on_row: Callable[[dict[str, Any]], None] | None = None,
) -> BatchSummary:
    """Plan every scene × spec on ``engine``; rows to ``out/plans``.

    With ``resume``, the plans already in ``out`` are skipped (and a spec whose
    content changed since is refused); ``record`` writes one MCAP per plan to
    ``out/runs/<spec>/<scene>.mcap``. A task plans ``chunk`` scene × spec
    pairs; a process that dies every time costs its task's plans (an ``error``
    row each).
    """
    from wsgrasp._names import gripper_ref
    from wsgrasp.gripper import load_gripper
    from wsgrasp.sim._pool import progress_bar

    labels = [s.label for s in specs]
    if len(set(labels)) != len(labels):
        raise InputError(
            f"spec labels repeat: {labels}",
            hint="name them: --spec mine=a.yaml --spec other=b.yaml",
        )
    payload: dict[str, Any] = {"specs": {}, "hashes": {}}
    models: dict[str, Any] = {}
    for s in specs:  # each gripper model built once, here
        base = s.spec.source.parent if s.spec.source is not None else Path.cwd()
        ref = gripper_ref(s.spec.gripper, base)
        if ref not in models:
            models[ref] = load_gripper(ref)
        payload["specs"][s.label] = (s.spec, models[ref])
        payload["hashes"][s.label] = spec_hash(s.spec)
    sink = PartSink(
        out,
        {"plans": plan_schema()},
        "plans",
        ("scene", "spec"),
        resume=resume,
        row_group=row_group,
    )
    if sink.done:
        _check_hashes(out, payload["hashes"])
    pairs = [(str(scene), s.label) for scene in scenes for s in specs]
    todo = [pairs[i] for i in sink.missing(pairs)]
    summary = BatchSummary(resumed=len(pairs) - len(todo))
    jobs: list[tuple[str, str, str | None]] = []
    for scene, label in todo:
        rec = None
        if record:
            rec = str(out / "runs" / label / f"{_slug(scene)}.mcap")
            Path(rec).parent.mkdir(parents=True, exist_ok=True)
        jobs.append((scene, label, rec))
    # tasks of `chunk` plans: fewer round trips per plan (a plan takes ~25 ms)
    tasks = [(jobs[i : i + chunk],) for i in range(0, len(jobs), max(1, chunk))]
    start = time.perf_counter()
    with progress_bar(progress and bool(jobs), "plans", len(jobs)) as advance:

        def done(i: int, rows: list[dict[str, Any]]) -> None:
            sink.add({"plans": rows})
            for row in rows:
                summary.planned += 1
                summary.found += bool(row.get("found"))
                if not row.get("found"):
                    reason = row.get("error") or row.get("hint") or "no grasp"
                    summary.failures.append(
                        {"scene": row["scene"], "spec": row["spec"], "reason": reason}
                    )
                if on_row is not None:
                    on_row(row)
                rate = summary.planned / max(time.perf_counter() - start, 1e-9)
                advance(f"{summary.found}/{summary.planned} found · {rate:.1f} plans/s")

        def crashed(i: int) -> None:
            rows = [
                _crash_row(scene, label, payload["hashes"][label])
                for scene, label, _ in tasks[i][0]
            ]
            done(i, rows)

        try:
            engine.run(plan_chunk, tasks, done, shared=payload, on_crash=crashed)
        finally:
            sink.flush()
    summary.wall_s = time.perf_counter() - start
    return summary


def _crash_row(scene: str, label: str, digest: str) -> dict[str, Any]:
    """The row of a plan whose process died every time it ran."""
    from wsgrasp._version import __version__

    return {
        "scene": scene,
        "spec": label,
        "found": False,
        "error": "WorkerCrashed: the process planning this scene died every time",
        "spec_hash": digest,
        "wsgrasp_version": __version__,
    }


def _check_hashes(out: Path, hashes: dict[str, str]) -> None:
    """Refuse to resume with a spec whose content differs from its rows'."""
    import pyarrow.parquet as pq

    t = pq.read_table(out / "plans", columns=["spec", "spec_hash"])
    before = dict(zip(t.column(0).to_pylist(), t.column(1).to_pylist(), strict=True))
    for label, digest in hashes.items():
        if label in before and before[label] != digest:
            raise InputError(
                f"spec {label!r} differs from the one {out} was planned with "
                f"(content {digest}, rows {before[label]})",
                hint="resume with the same spec, label the new one differently "
                "(--spec new=FILE), or choose another output folder",
            )
