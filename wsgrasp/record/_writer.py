"""The MCAP recorder: a plan observer that writes every stage as it ends.

Layout of a run file (``FORMAT_VERSION`` 2):

- header profile ``wsgrasp``; metadata ``wsgrasp`` (format and package versions,
  platform, seed, gripper), ``spec`` (the resolved spec as JSON), ``plugins``
  (every plugin's distribution and version) and, last, ``run_end``;
- attachments: ``gripper/model.npz`` (the built model, exact arrays),
  ``gripper/description.json`` and, when found, the gripper YAML and URDF;
- full-fidelity channels (``/wsgrasp/...``, schema ``wsgrasp.Record``, see
  :mod:`._codec`) and channels in Foxglove's well-known schemas for looking at the
  run.

The inputs are written and flushed in ``on_start``, before any processing, and each
stage's full-fidelity record is flushed (a zstd chunk of its own) when the stage
ends, in the planner's thread: a crash, even one that kills the process, leaves a
file that :func:`~wsgrasp.record.open_run` reads up to the last finished stage.
The Foxglove views of every stage and the file's end (the summary) are written
after the result or the error, by the process's writer thread, so that the plan
returns without waiting for them; ``close()`` waits, and so do a new recording
before its plan and ``open_run`` (see :class:`RunRecorder`).

What keeps recording cheap (the issue's budget is 20 % of the plan time):

- float64 arrays that are exactly float32 (sensor clouds) are stored as float32
  (:func:`~wsgrasp.record._codec.as_float32_exact`), bit-exact;
- the merged scene points are not stored when they are the merge of the recorded
  views (known from the loader's digest, :meth:`Scene.is_merge`, or checked
  here), with a check value the reader checks again: ``"points": "merge(views)"``;
- chunks zstd cannot shrink (float clouds) are stored as raw zstd blocks
  (:mod:`._mcapio`), without compressing or copying, and written with one
  ``writev``;
- the gripper model's attachment and Foxglove shapes are encoded once per model;
- the Foxglove views are built after the plan, and the input views are thinned to
  :data:`FOXGLOVE_MAX_POINTS` points. Building them during the plan on another
  thread would not help: it is Python work, and holding the GIL it would stall
  the planner.
"""

from __future__ import annotations

import atexit
import json
import os
import platform
import queue
import sys
import threading
import time
import weakref
from collections.abc import Callable, Iterator
from contextlib import contextmanager, suppress
from dataclasses import fields, is_dataclass
from datetime import datetime, timezone
from pathlib import Path
from types import SimpleNamespace
from typing import IO, TYPE_CHECKING, Any, NamedTuple

import numpy as np
import xxhash
from numpy.typing import NDArray

from wsgrasp.errors import RecordingError
from wsgrasp.record import _foxglove as fx
from wsgrasp.record._codec import FORMAT_VERSION, PROFILE, TOPICS, dumps_parts
from wsgrasp.record._mcapio import ChunkWriter
from wsgrasp.record._proto import DESCRIPTOR_SET, SCHEMA_NAME

if TYPE_CHECKING:
    from wsgrasp.gripper.model import GripperModel
    from wsgrasp.perception.types import Scene
    from wsgrasp.planning.result import PlanResult
    from wsgrasp.spec import PipelineSpec

__all__ = ["RunRecorder", "default_run_path", "FOXGLOVE_MAX_POINTS"]

#: Most points of the input views, all together, in their Foxglove channels
#: (``/inputs/view<i>``; the exact views are in ``/wsgrasp/inputs``).
FOXGLOVE_MAX_POINTS = 30_000

#: The merged points are the merge of the views (``wsgrasp.perception.io``).
MERGED = "merge(views)"

#: A message's bytes, whole or in pieces (see ``ChunkWriter.add_message``).
_Payload = bytes | list[bytes | memoryview]

#: Recorders with a file still open; finished at interpreter exit.
_OPEN: weakref.WeakSet[RunRecorder] = weakref.WeakSet()
#: Guards ``_OPEN`` and ``_PENDING``, which the writer thread changes too.
_REGISTRY = threading.Lock()


def thin_for_view(points: Any, step: int) -> Any:
    """Every ``step``-th point of ``points`` (n, 3)."""
    return points if step <= 1 else points[::step]


def view_step(sizes: list[int], limit: int | None = None) -> int:
    """The step that leaves at most ``limit`` (:data:`FOXGLOVE_MAX_POINTS`)
    points of clouds of ``sizes``."""
    limit = FOXGLOVE_MAX_POINTS if limit is None else limit
    return max(1, -(-sum(sizes) // limit))


class _Worker:
    """The process's writer thread: runs jobs in order (starting a thread can
    take milliseconds on a busy machine, so one serves every recorder)."""

    _jobs: queue.SimpleQueue[Callable[[], None]] = queue.SimpleQueue()
    _thread: threading.Thread | None = None
    _lock = threading.Lock()

    @classmethod
    def start(cls) -> None:
        with cls._lock:
            if cls._thread is None or not cls._thread.is_alive():
                cls._thread = threading.Thread(
                    target=cls._serve, name="wsgrasp-recorder", daemon=True
                )
                cls._thread.start()

    @classmethod
    def _serve(cls) -> None:
        while True:
            cls._jobs.get()()

    @classmethod
    def submit(cls, job: Callable[[], None]) -> None:
        cls.start()
        cls._jobs.put(job)


#: The views are written in chunks of at least this many bytes (fewer chunks,
#: less per-chunk work), the last one excepted.
_VIEW_CHUNK = 256 * 1024

#: Recorders whose file the writer thread is finishing.
_PENDING: weakref.WeakSet[RunRecorder] = weakref.WeakSet()


def wait_for_recorders() -> None:
    """Wait until the writer thread has finished every recording handed to it
    (a new recording calls this before its plan starts)."""
    with _REGISTRY:
        pending = list(_PENDING)
    for rec in pending:
        rec.wait()


def _forget_after_fork() -> None:
    """In a forked child: the parent's recordings are the parent's to finish (a
    child finishing them at exit would write into the parent's files), and the
    writer thread was not copied."""
    global _REGISTRY
    _REGISTRY = threading.Lock()  # another thread may have held it at the fork
    _OPEN.clear()
    _PENDING.clear()
    _Worker._jobs = queue.SimpleQueue()
    _Worker._thread = None
    _Worker._lock = threading.Lock()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_forget_after_fork)


@atexit.register
def _close_open_recorders() -> None:
    """A recorder left open (no result, no error reported) is finished at exit,
    so that what was queued reaches the file."""
    with _REGISTRY:
        still_open = list(_OPEN)
    for rec in still_open:
        try:
            rec.close()
        except Exception:  # noqa: BLE001, S110 - exiting anyway
            pass


def default_run_path(
    spec: PipelineSpec, gripper_name: str, *, now: datetime | None = None
) -> Path:
    """Where ``plan`` records by default:
    ``<spec.record.dir>/<UTC time>-<gripper>.mcap``.

    The time has microseconds, so two runs in one second get two files.
    """
    t = (now or datetime.now(timezone.utc)).astimezone(timezone.utc)
    stamp = t.strftime("%Y%m%dT%H%M%S.%fZ")
    safe = "".join(c if c.isalnum() or c in "-_." else "_" for c in gripper_name)
    return Path(spec.record.dir) / f"{stamp}-{safe or 'gripper'}.mcap"


def check_record_path(path: str | Path, *, force: bool = False) -> Path:
    """Refuse to overwrite an existing recording unless ``force``.

    Raises
    ------
    RecordingError
        ``path`` exists (and ``force`` is False), or is a directory.
    """
    p = Path(path)
    if p.is_dir():
        raise RecordingError(
            f"{p}: is a directory, not a recording file",
            hint="give a file path ending in .mcap",
        )
    if p.exists() and not force:
        raise RecordingError(
            f"{p}: a recording already exists there; wsgrasp never overwrites one",
            hint="choose another path, or pass --force to replace it",
        )
    return p


class RunRecorder:
    """Record one plan to an MCAP file; pass it to ``Pipeline.plan(observers=...)``.

    In the planner's thread, ``on_start`` writes the metadata, the gripper model
    and the exact inputs, and flushes them, before it returns; each ``on_stage``
    writes and flushes its stage's full-fidelity record, ``on_result`` the result.
    A process killed outright keeps every finished stage.

    The Foxglove views (point clouds, poses, shapes: for looking at) are built
    after the result, on the process's writer thread, which then finishes the
    file: the plan returns without waiting for them, and they are built while the
    caller goes on (a robot moving to the grasp). :meth:`close` waits for them; a
    new recording waits for the previous ones before its plan starts, so finishing
    never competes with planning. A plan that raises gets the views of the stages
    before the error the same way.

    Parameters
    ----------
    path
        The ``.mcap`` file to write. Its directory is created.
    force
        Replace an existing file. Without it an existing file is an error, raised
        here, before the plan starts.

    Attributes
    ----------
    path : Path
    overhead_ms : float
        Time the planner's thread spent inside the recorder.
    views_ms : float
        Time the writer thread spent building the Foxglove views.
    finish_ms : float
        Time the writer thread spent on the views and the file's end (summary).
    """

    def __init__(self, path: str | Path, *, force: bool = False) -> None:
        self.path = check_record_path(path, force=force)
        self.force = force
        self.overhead_ms = 0.0
        self.views_ms = 0.0
        self.finish_ms = 0.0
        self._writer: ChunkWriter | None = None
        self._stream: IO[bytes] | None = None
        self._schemas: dict[str, int] = {}
        self._channels: dict[str, int] = {}
        self._gripper: GripperModel | None = None
        self._model_key: tuple[Any, ...] | None = None
        self._table_axes: tuple[float, float, float] | None = None
        self._candidates: Any = None
        self._stages_written: list[str] = []
        self._queued: list[tuple[str, Callable[[], None]]] = []
        self._finished = False  # no more hooks taken
        self._done: threading.Event | None = None  # set when the file is finished
        self._error: BaseException | None = None  # a failure on the writer thread
        _Worker.start()  # now, not in the plan's time

    # -- PlanObserver ------------------------------------------------------------
    def on_start(self, spec: PipelineSpec, gripper: GripperModel, scene: Scene) -> None:
        """Write metadata, the gripper model and the inputs, and flush."""
        wait_for_recorders()  # earlier runs' views: not while this one plans
        t0 = time.perf_counter()
        # what the views need of the spec, as it is now (the caller may change
        # the spec before the writer thread builds them)
        a, b, c = spec.table.semi_axes
        self._table_axes = (float(a), float(b), float(c))
        self._gripper = gripper
        self._open()
        with self._writing():
            self._write_start(spec, gripper, scene)
        self.overhead_ms += (time.perf_counter() - t0) * 1e3

    def _write_start(
        self, spec: PipelineSpec, gripper: GripperModel, scene: Scene
    ) -> None:
        w = self._w
        w.add_metadata("wsgrasp", _run_metadata(spec, gripper))
        w.add_metadata("spec", _spec_metadata(spec))
        w.add_metadata("plugins", _plugins_metadata())
        now = time.time_ns()
        self._model_key = _model_key(gripper)
        for name, media, data in _gripper_attachments(spec, gripper, self._model_key):
            w.add_attachment(now, name, media, data)
        topic = TOPICS["inputs"]
        self._put(topic, SCHEMA_NAME, self._encode(topic, _inputs_record(scene)), now)
        w.flush(fast=True)
        views = _snapshot([(v.points, v.T_world_camera) for v in scene.views])
        self._queue("inputs", lambda: self._foxglove_inputs(views, now))

    def on_stage(self, stage: str, data: dict[str, Any]) -> None:
        """Write one stage's record and flush; queue its Foxglove views."""
        if self._writer is None or self._finished:
            return
        t0 = time.perf_counter()
        now = time.time_ns()
        topic = TOPICS.get(stage, f"/wsgrasp/stage/{stage}")
        with self._writing():
            self._put(topic, SCHEMA_NAME, self._encode(topic, data), now)
            self._w.flush(fast=True)
        if stage == "candidates":
            self._candidates = data.get("candidates")
        self._stages_written.append(stage)
        fox = getattr(self, f"_fox_{stage}", None)
        if fox is not None:
            snap = _snapshot(data)
            self._queue(stage, lambda: fox(snap, now))
        self.overhead_ms += (time.perf_counter() - t0) * 1e3

    def on_result(self, result: PlanResult) -> None:
        """Write the result and flush; the writer thread adds the Foxglove views
        and finishes the file."""
        if self._writer is None or self._finished:
            return
        t0 = time.perf_counter()
        now = time.time_ns()
        topic = TOPICS["result"]
        record = _result_record(result, self._candidates)
        with self._writing():
            self._put(topic, SCHEMA_NAME, self._encode(topic, record), now)
            self._w.flush(fast=True)
        snap = SimpleNamespace(  # what the views show, copied
            found=result.found,
            T_world_ee=_snapshot(result.T_world_ee),
            contacts=_snapshot(result.contacts),
        )
        self._queue("result", lambda: self._fox_result(snap, now))
        self._finish_later("ok")
        self.overhead_ms += (time.perf_counter() - t0) * 1e3

    def on_error(self, error: BaseException) -> None:
        """Write what stopped the plan and flush; the writer thread adds the
        Foxglove views of the stages before it and finishes the file."""
        if self._writer is None or self._finished:
            return
        t0 = time.perf_counter()
        now = time.time_ns()
        record = {
            "type": getattr(error, "type_name", None) or type(error).__name__,
            "message": getattr(error, "message", str(error)),
            "hint": getattr(error, "hint", None),
            "stages": list(self._stages_written),
        }
        topic = TOPICS["error"]
        with self._writing():
            self._put(topic, SCHEMA_NAME, self._encode(topic, record), now)
            self._w.flush(fast=True)
        self._finish_later("error")
        self.overhead_ms += (time.perf_counter() - t0) * 1e3

    def close(self) -> None:
        """Wait until the file is finished; finish it here if the plan never
        reported a result or an error (safe to call twice).

        Raises
        ------
        RecordingError
            Writing the views or the file's end failed (the run's records, written
            before, are in the file).
        """
        if self._writer is None:
            return
        if not self._finished:
            self._finish_later("closed")
        self.wait()
        error, self._error = self._error, None
        if error is not None:
            raise RecordingError(
                f"{self.path}: finishing the recording failed: {error!r}; the run "
                "itself (inputs, stages, result) is recorded",
                hint="check free disk space and the file system",
            ) from error

    def wait(self) -> None:
        """Wait for the writer thread to finish this recording's file."""
        if self._done is not None:
            self._done.wait()

    def __enter__(self) -> RunRecorder:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- plumbing ----------------------------------------------------------------
    @property
    def _w(self) -> ChunkWriter:
        assert self._writer is not None
        return self._writer

    @contextmanager
    def _writing(self) -> Iterator[None]:
        """Turn a failed write (disk full, file system gone) into one
        ``RecordingError``; the file keeps what was flushed before, and the
        recorder writes nothing more."""
        try:
            yield
        except OSError as exc:
            self._finished = True
            self._close_stream()
            raise RecordingError(
                f"{self.path}: writing the recording failed: "
                f"{exc.strerror or exc}; the file keeps the stages written before",
                hint="free disk space or record elsewhere (--record PATH), or plan "
                "with --no-record",
            ) from exc

    def _close_stream(self) -> None:
        with _REGISTRY:
            _OPEN.discard(self)
        if self._stream is not None:
            with suppress(OSError):
                self._stream.close()

    def _queue(self, stage: str, build: Callable[[], None]) -> None:
        self._queued.append((stage, build))

    def _finish_later(self, status: str) -> None:
        """Hand the queued views and the file's end to the writer thread."""
        self._finished = True
        self._done = threading.Event()
        queued, self._queued = self._queued, []
        with _REGISTRY:
            _PENDING.add(self)

        def job() -> None:
            t0 = time.perf_counter()
            try:
                for stage, build in queued:
                    self._views(stage, build)
                    if self._w.pending_bytes >= _VIEW_CHUNK:
                        self._w.flush(fast=True)
                self._finish(status)  # writes the last chunk
            except BaseException as exc:  # noqa: BLE001 - raised by close()
                self._error = exc
                self._close_stream()
            finally:
                self.finish_ms += (time.perf_counter() - t0) * 1e3
                with _REGISTRY:
                    _PENDING.discard(self)
                assert self._done is not None
                self._done.set()

        _Worker.submit(job)

    def _views(self, stage: str, build: Callable[[], None]) -> None:
        """Add a stage's Foxglove views to the chunk in progress (``build`` calls
        :meth:`_fox`). A view that fails to build is a warning in the run, not a
        failed recording: the views are for looking at."""
        t0 = time.perf_counter()
        try:
            build()
        except Exception as exc:  # noqa: BLE001 - views are a convenience
            value = {"stage": stage, "error": repr(exc)}
            data = self._encode("/wsgrasp/warnings", value)
            self._put("/wsgrasp/warnings", SCHEMA_NAME, data, time.time_ns())
        self.views_ms += (time.perf_counter() - t0) * 1e3

    def _open(self) -> None:
        if self._writer is not None:
            raise RecordingError(
                f"{self.path}: this recorder already recorded a run",
                hint="make one RunRecorder per plan",
            )
        self.path.parent.mkdir(parents=True, exist_ok=True)
        try:
            raw = open(self.path, "wb" if self.force else "xb")  # noqa: SIM115
        except FileExistsError:
            raise RecordingError(
                f"{self.path}: a recording already exists there; wsgrasp never "
                "overwrites one",
                hint="choose another path, or pass --force to replace it",
            ) from None
        except OSError as exc:
            raise RecordingError(
                f"{self.path}: cannot create the recording: {exc.strerror}",
                hint="check the directory exists and is writable, or use --no-record",
            ) from None
        self._stream = raw
        from wsgrasp import __version__

        self._writer = ChunkWriter(raw)
        self._writer.start(profile=PROFILE, library=f"wsgrasp {__version__}")
        with _REGISTRY:
            _OPEN.add(self)

    def _finish(self, status: str) -> None:
        """Write the file's end (the ``run_end`` metadata, the summary) and close
        it."""
        try:
            self._w.add_metadata(
                "run_end",
                {
                    "status": status,
                    "stages": ",".join(self._stages_written),
                    "finished_utc": datetime.now(timezone.utc).isoformat(),
                    "recorder_ms": f"{self.overhead_ms:.3f}",
                    "views_ms": f"{self.views_ms:.3f}",
                },
            )
            self._w.finish()
        finally:
            self._close_stream()

    def _schema_id(self, name: str) -> int:
        sid = self._schemas.get(name)
        if sid is None:
            if name.startswith("foxglove."):
                encoding, data = fx.schema_of(name)
            else:
                encoding, data = "protobuf", DESCRIPTOR_SET
            sid = self._w.register_schema(name=name, encoding=encoding, data=data)
            self._schemas[name] = sid
        return sid

    def _channel_id(self, topic: str, schema: str) -> int:
        cid = self._channels.get(topic)
        if cid is None:
            cid = self._w.register_channel(
                topic=topic,
                message_encoding="protobuf",
                schema_id=self._schema_id(schema),
                metadata={"wsgrasp_format": str(FORMAT_VERSION)},
            )
            self._channels[topic] = cid
        return cid

    def _put(self, topic: str, schema: str, data: _Payload, t_ns: int) -> None:
        cid = self._channel_id(topic, schema)
        self._w.add_message(cid, t_ns, data)

    @staticmethod
    def _encode(topic: str, value: Any) -> _Payload:
        """The record's bytes, in pieces that view the arrays in ``value``: write
        them (and flush) before the caller can change those arrays."""
        return dumps_parts(value, topic.removeprefix("/wsgrasp/"))

    def _fox(self, topic: str, msg: tuple[str, _Payload], t_ns: int) -> None:
        """Add a Foxglove view to the chunk in progress."""
        self._put(topic, msg[0], msg[1], t_ns)

    # -- Foxglove views of each stage ---------------------------------------------
    def _foxglove_inputs(self, views: list[tuple[Any, Any]], t: int) -> None:
        """The input views for looking at, thinned by one step to at most
        :data:`FOXGLOVE_MAX_POINTS` points in all (the exact views are in
        ``/wsgrasp/inputs``)."""
        step = view_step([len(p) for p, _ in views])
        for i, (points, T_world_camera) in enumerate(views):
            frame = f"camera{i}"
            self._fox("/tf", fx.frame_transform(T_world_camera, "world", frame, t), t)
            pc = fx.point_cloud(thin_for_view(points, step), frame, t)
            self._fox(f"/inputs/view{i}", pc, t)

    def _fox_preprocess(self, d: dict[str, Any], t: int) -> None:
        if "points" in d:
            self._fox(
                "/scene/downsampled",
                fx.point_cloud(d["points"], "world", t, rgba=(0.7, 0.7, 0.7, 1.0)),
                t,
            )

    def _fox_segmentation(self, d: dict[str, Any], t: int) -> None:
        if d.get("table_points") is not None:
            pc = fx.point_cloud(d["table_points"], "world", t, rgba=(0.6, 0.5, 0.4, 1))
            self._fox("/scene/table_points", pc, t)
        if d.get("object_points") is not None:
            pc = fx.point_cloud(d["object_points"], "world", t, rgba=(0.1, 0.4, 0.9, 1))
            self._fox("/scene/object", pc, t)
        obstacles = [np.asarray(o).reshape(-1, 3) for o in d.get("obstacles") or []]
        if obstacles:
            pts = np.concatenate(obstacles)  # (k, 3)
            pc = fx.point_cloud(pts, "world", t, rgba=(0.9, 0.5, 0.1, 1.0))
            self._fox("/scene/obstacles", pc, t)

    def _fox_object_frame(self, d: dict[str, Any], t: int) -> None:
        ents: list[tuple[str, list[Any], list[Any]]] = []
        if d.get("T_world_object") is not None:
            T = np.asarray(d["T_world_object"])
            self._fox("/tf", fx.frame_transform(T, "world", "object", t), t)
            self._fox("/object/frame", fx.pose_in_frame(T, "world", t), t)
            if d.get("extents") is not None:
                ents.append(
                    (
                        "object_box",
                        [fx.cube(T, d["extents"], (0.1, 0.4, 0.9, 0.15))],
                        [],
                    )
                )
        if d.get("samples_world") is not None:
            pc = fx.point_cloud(
                d["samples_world"], "world", t, rgba=(1.0, 0.85, 0.1, 1)
            )
            self._fox("/object/samples", pc, t)
        if d.get("T_world_table") is not None and self._table_axes is not None:
            T = np.asarray(d["T_world_table"])
            self._fox("/tf", fx.frame_transform(T, "world", "table", t), t)
            a, b, c = self._table_axes
            T_centre = T.copy()
            T_centre[:3, 3] = T[:3, :3] @ np.array([0.0, 0.0, -c]) + T[:3, 3]
            ents.append(
                (
                    "table_se",
                    [fx.cube(T_centre, (2 * a, 2 * b, 2 * c), (0.6, 0.5, 0.4, 0.3))],
                    [],
                )
            )
        if ents:
            self._fox("/scene/shapes", fx.scene_update(ents, "world", t), t)

    def _fox_candidates(self, d: dict[str, Any], t: int) -> None:
        from wsgrasp.planning.result import REASONS

        cs = d.get("candidates")
        if cs is None or len(cs.reason) == 0:
            return
        reason = np.asarray(cs.reason)
        # the poses grouped by reason, in the order of REASONS; encoded at once
        order = np.argsort(reason, kind="stable")
        counts = np.bincount(reason, minlength=len(REASONS))
        columns = fx.pose_columns(np.asarray(cs.T_world_ee)[order])  # (C, 7)
        groups = fx.poses_in_frame_groups(columns, counts.tolist(), "world", t)
        names = [*REASONS, *(f"reason_{i}" for i in range(len(REASONS), len(counts)))]
        for name, n, msg in zip(names, counts.tolist(), groups, strict=True):
            if n:
                self._fox(f"/candidates/{name}", msg, t)
        colors = np.array([fx.reason_rgba(n) for n in REASONS])  # (R, 4)
        code = np.clip(reason, 0, len(REASONS) - 1)
        pts = np.asarray(cs.T_world_gwc)[:, :3, 3]  # (C, 3)
        self._fox(
            "/candidates/points", fx.point_cloud(pts, "world", t, rgba=colors[code]), t
        )

    def _fox_result(self, result: Any, t: int) -> None:
        """The chosen pose, the gripper there (its cloud, body superellipsoids
        and workspace spheres, the ones holding object points highlighted) and
        the contacts. The gripper is drawn in frame ``gripper``, which ``/tf``
        puts at the chosen pose, so its shapes are encoded once per model."""
        g = self._gripper
        if not result.found or result.T_world_ee is None or g is None:
            return
        T = np.asarray(result.T_world_ee)
        self._fox("/grasp/pose", fx.pose_in_frame(T, "world", t), t)
        self._fox("/tf", fx.frame_transform(T, "world", "gripper", t), t)
        assert self._model_key is not None  # set with the gripper
        shapes = _gripper_shapes(g, self._model_key)
        self._fox("/grasp/gripper_cloud", fx.point_cloud(shapes.cloud, "gripper", t), t)
        held = np.zeros(len(shapes.spheres), dtype=bool)
        for contact in result.contacts:
            held[np.asarray(contact.spheres, dtype=np.int64)] = True
        ents = [
            ("gripper_body", shapes.body, []),
            ("workspace_spheres", [], fx.Spheres(shapes.spheres[~held].tobytes())),
            ("holding_spheres", [], fx.Spheres(shapes.held[held].tobytes())),
        ]
        self._fox("/grasp/gripper", fx.scene_update(ents, "gripper", t), t)
        pts = [np.asarray(c.points).reshape(-1, 3) for c in result.contacts]
        if pts:
            self._fox(
                "/grasp/contacts",
                fx.point_cloud(
                    np.concatenate(pts), "world", t, rgba=(0.1, 0.9, 0.2, 1.0)
                ),
                t,
            )


class _GripperShapes(NamedTuple):
    """A gripper's Foxglove shapes in its own frame (see ``_fox_result``)."""

    cloud: NDArray[np.float32]  # (n, 3)
    body: list[Any]  # cube primitives, one per superellipsoid
    spheres: NDArray[np.void]  # (S,) encoded sphere primitives, faint
    held: NDArray[np.void]  # (S,) the same, highlighted


#: :class:`_GripperShapes` by model fingerprint (:func:`_model_key`)
_SHAPES: dict[tuple[Any, ...], _GripperShapes] = {}


def _gripper_shapes(g: GripperModel, key: tuple[Any, ...]) -> _GripperShapes:
    """``g``'s shapes, made once per model fingerprint ``key``."""
    shapes = _SHAPES.get(key)
    if shapes is None:
        body = []
        for c, s in zip(
            np.asarray(g.se_centers), np.asarray(g.se_semi_axes), strict=True
        ):
            Tc = np.eye(4)
            Tc[:3, 3] = c
            body.append(fx.cube(Tc, 2 * s, (0.5, 0.5, 0.55, 0.35)))
        centers = np.asarray(g.sphere_centers, dtype=np.float64).reshape(-1, 3)
        radii = np.asarray(g.sphere_radii, dtype=np.float64).reshape(-1)

        def rows(rgba: tuple[float, ...]) -> NDArray[np.void]:
            data = bytes(fx.spheres(centers, radii, rgba))
            size = len(data) // len(radii) if len(radii) else 1
            return np.frombuffer(data, dtype=f"V{size}")

        shapes = _GripperShapes(
            cloud=np.ascontiguousarray(g.cloud, dtype="<f4"),
            body=body,
            spheres=rows((0.3, 0.6, 1.0, 0.15)),
            held=rows((0.1, 0.9, 0.2, 0.6)),
        )
        if len(_SHAPES) >= 8:
            _SHAPES.clear()
        _SHAPES[key] = shapes
    return shapes


#: arrays up to this many values are copied for the views built later (the
#: caller may hold them: poses, contacts, candidates); larger ones are the
#: planner's own clouds, which nothing changes
_COPY_MAX = 1 << 16


def _snapshot(value: Any) -> Any:
    """``value`` with its small arrays copied (see :data:`_COPY_MAX`), for the
    Foxglove views the writer thread builds after the plan has returned;
    dataclasses become namespaces of their fields (nothing is validated again)."""
    if isinstance(value, np.ndarray):
        return value.copy() if value.size <= _COPY_MAX else value
    if isinstance(value, dict):
        return {k: _snapshot(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_snapshot(v) for v in value]
    if is_dataclass(value) and not isinstance(value, type):
        return SimpleNamespace(
            **{f.name: _snapshot(getattr(value, f.name)) for f in fields(value)}
        )
    return value


# -- records -----------------------------------------------------------------------
def _run_metadata(spec: PipelineSpec, gripper: GripperModel) -> dict[str, str]:
    from wsgrasp import __version__

    return {
        "format_version": str(FORMAT_VERSION),
        "wsgrasp_version": __version__,
        "created_utc": datetime.now(timezone.utc).isoformat(),
        "gripper": gripper.name,
        "gripper_hash": gripper.source_hash,
        "seed": str(spec.seed),
        "python": platform.python_version(),
        "platform": platform.platform(),
        "numpy": np.__version__,
        "command": " ".join(sys.argv[:1] + sys.argv[1:])[:2000],
    }


def _spec_metadata(spec: PipelineSpec) -> dict[str, str]:
    return {
        "json": spec.model_dump_json(),  # pydantic's own encoder: 4x faster
        "source": "" if spec.source is None else str(spec.source),
    }


def _plugins_metadata() -> dict[str, str]:
    try:
        from wsgrasp.plugins import get_registry

        summary = get_registry().plugin_summary()
    except Exception as exc:  # noqa: BLE001 - recorded, not fatal
        return {"error": repr(exc)}
    return {
        f"{p['distribution']}:{p['name']}": json.dumps(p, sort_keys=True)
        for p in summary
    }


def _inputs_record(scene: Scene) -> dict[str, Any]:
    """The inputs, exact. The merged points are stored once more unless merging
    the views as ``wsgrasp.perception.io`` does gives them bit for bit (known
    from :meth:`~wsgrasp.perception.types.Scene.is_merge` for a loader's scene,
    checked for any other); then
    ``points`` is :data:`MERGED`, and when the merge computed anything (a view not
    at the identity) ``points_check`` is :func:`points_check` of them, which the
    reader checks on its own merge."""
    views = scene.views
    record: dict[str, Any] = {
        "views": [
            {"name": v.name, "points": v.points, "T_world_camera": v.T_world_camera}
            for v in views
        ],
        "points": scene.points,
        "dropped_nonfinite": int(scene.dropped_nonfinite),
    }
    pairs = [(v.points, v.T_world_camera) for v in views]
    # a loader's scene, unchanged since it merged the views, is their merge; any
    # other scene is checked
    if (
        _is_its_only_view(pairs, scene.points)
        or scene.is_merge()
        or is_merge_of(pairs, scene.points)
    ):
        record["points"] = MERGED
        if any(not np.array_equal(T, np.eye(4)) for _, T in pairs):
            # computed, so the reader's own merge is checked against it
            record["points_check"] = points_check(scene.points)
    return record


def merge_views(views: list[tuple[Any, Any]]) -> NDArray[np.float64]:
    """The views ``(points (n_i, 3), T_world_camera (4, 4))`` in the world frame,
    concatenated (N, 3), as the scene loader merges them (``_to_world`` of
    :mod:`wsgrasp.perception.io`)."""
    from wsgrasp.perception.io import _to_world
    from wsgrasp.perception.types import View

    world = [
        _to_world(View(points=np.asarray(p), T_world_camera=np.asarray(T)))
        for p, T in views
    ]
    return np.concatenate(world, axis=0)


#: rows per block when checking a merge (a block's buffers stay in cache)
_BLOCK = 16384


def _is_its_only_view(views: list[tuple[Any, Any]], points: Any) -> bool:
    """Whether ``points`` is the very array of the only view, posed at the
    identity (float64 (n, 3)): its own merge."""
    return (
        len(views) == 1
        and views[0][0] is points
        and isinstance(points, np.ndarray)
        and points.dtype == np.float64
        and points.ndim == 2
        and points.shape[1] == 3
        and np.array_equal(np.asarray(views[0][1], dtype=np.float64), np.eye(4))
    )


def is_merge_of(views: list[tuple[Any, Any]], points: Any) -> bool:
    """Whether ``points`` (N, 3) is bit for bit :func:`merge_views` of ``views``.

    Computed block by block into one small buffer, with the loader's own
    operations (``p @ R.T + t``; a view posed at the identity as it is): several
    times faster than merging again, which is mostly fresh memory. Should a block
    come out different from the whole-array product (another BLAS kernel for small
    matrices), the answer is False and the points are stored: never a wrong True.
    """
    if _is_its_only_view(views, points):
        return True
    pts = np.asarray(points)
    arrays = [np.asarray(p) for p, _ in views]
    if (
        not arrays
        or pts.dtype != np.float64
        or pts.shape != (sum(len(a) for a in arrays), 3)
        or any(a.dtype != np.float64 or a.ndim != 2 or a.shape[1] != 3 for a in arrays)
    ):
        return False
    pts = np.ascontiguousarray(pts)
    buf = np.empty((_BLOCK, 3))
    off = 0
    for a, (_, T) in zip(arrays, views, strict=True):
        T = np.asarray(T, dtype=np.float64)
        identity = np.array_equal(T, np.eye(4))
        R_t, t = T[:3, :3].T, T[:3, 3]
        for i in range(0, len(a), _BLOCK):
            part = a[i : i + _BLOCK]
            if identity:
                block = np.ascontiguousarray(part)
            else:
                block = buf[: len(part)]
                np.matmul(part, R_t, out=block)
                np.add(block, t, out=block)
            want = pts[off + i : off + i + len(part)]
            if not np.array_equal(block.view(np.int64), want.view(np.int64)):
                return False
        off += len(a)
    return True


def points_check(points: Any) -> str:
    """A check value of float64 ``points``: the sum (mod 2^64) and the xor of their
    64-bit words, in hex. Any one changed value changes it; so does a merge done
    with other rounding (many changed values) save by a freak of chance. Ten times
    cheaper than a CRC-32."""
    words = np.ascontiguousarray(points, dtype="<f8").reshape(-1).view("<u8")
    total = int(np.add.reduce(words, dtype=np.uint64))
    mixed = int(np.bitwise_xor.reduce(words)) if words.size else 0
    return f"{total:016x}{mixed:016x}"


def _result_record(result: PlanResult, stage_candidates: Any) -> dict[str, Any]:
    record: dict[str, Any] = {}
    for f in fields(result):
        value = getattr(result, f.name)
        if f.name == "candidates" and value is stage_candidates and value is not None:
            value = "stage:candidates"  # the same object, already recorded
        record[f.name] = value
    return record


def _model_key(gripper: GripperModel) -> tuple[Any, ...]:
    """A fingerprint of the model's exact content: every array's XXH3 (tens of
    microseconds for a model) and every other field's JSON."""
    key: list[Any] = [type(gripper).__qualname__]
    for f in fields(gripper):
        v = getattr(gripper, f.name)
        if isinstance(v, np.ndarray):
            a = np.ascontiguousarray(v)
            key.append((f.name, a.dtype.str, a.shape, xxhash.xxh3_64_intdigest(a.data)))
        else:
            key.append((f.name, json.dumps(v, sort_keys=True, default=repr)))
    return tuple(key)


#: the attachments by model fingerprint and the gripper files' paths and stats
_ATTACHMENTS: dict[tuple[Any, ...], list[tuple[str, str, bytes]]] = {}


def _file_stat(path: Path) -> tuple[str, int, int] | None:
    try:
        st = path.stat()
    except OSError:
        return None
    return (str(path), st.st_mtime_ns, st.st_size)


def _gripper_attachments(
    spec: PipelineSpec, gripper: GripperModel, model_key: tuple[Any, ...]
) -> list[tuple[str, str, bytes]]:
    """The attachments of a run's gripper: the model, its description and, when
    found, its YAML and URDF; built once per model and files (their size and
    modification time)."""
    yaml_path = _gripper_yaml(spec)
    urdf_path = None
    urdf = gripper.description.get("urdf")
    if yaml_path is not None and urdf:
        urdf_path = (yaml_path.parent / urdf).resolve()
    key = (  # the model's fingerprint covers its description too
        model_key,
        None if yaml_path is None else _file_stat(yaml_path),
        None if urdf_path is None else _file_stat(urdf_path),
    )
    out = _ATTACHMENTS.get(key)
    if out is None:
        out = _read_gripper_attachments(gripper, yaml_path, urdf_path)
        if len(_ATTACHMENTS) >= 8:
            _ATTACHMENTS.clear()
        _ATTACHMENTS[key] = out
    return out


def _read_gripper_attachments(
    gripper: GripperModel, yaml_path: Path | None, urdf_path: Path | None
) -> list[tuple[str, str, bytes]]:
    out = [
        # a compressed npz takes milliseconds: once per model and files
        ("gripper/model.npz", "application/x-npz", gripper.to_bytes()),
        (
            "gripper/description.json",
            "application/json",
            json.dumps(gripper.description, sort_keys=True, default=str).encode(),
        ),
    ]
    if yaml_path is not None:
        try:
            out.append(
                (
                    f"gripper/{yaml_path.name}",
                    "application/yaml",
                    yaml_path.read_bytes(),
                )
            )
            if urdf_path is not None and urdf_path.is_file():
                out.append(
                    (
                        f"gripper/{urdf_path.name}",
                        "application/xml",
                        urdf_path.read_bytes(),
                    )
                )
        except OSError:
            pass
    return out


def _gripper_yaml(spec: PipelineSpec) -> Path | None:
    """The gripper YAML the spec names, when there is one on disk."""
    name = spec.gripper
    candidates: list[Path] = []
    if name.endswith((".yaml", ".yml")) or "/" in name:
        candidates.append(Path(name))
        if spec.source is not None:
            candidates.append(Path(spec.source).parent / name)
    else:
        try:
            from wsgrasp.plugins import get_registry

            obj = get_registry().get("grippers", name).obj
        except Exception:  # noqa: BLE001 - an attachment is a convenience
            return None
        if isinstance(obj, (str, Path)):
            candidates.append(Path(obj))
    for c in candidates:
        if c.is_file():
            return c
    return None
