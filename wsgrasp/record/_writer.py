"""The MCAP recorder: a plan observer that writes every stage as it ends.

A run file, written with ``mcap.writer.Writer`` (profile ``wsgrasp``): the
``/wsgrasp/run`` record (:mod:`._runinfo`), also as metadata; the gripper
attachments; the full-fidelity records (:mod:`._codec`), each flushed as a chunk of
its own in the planner's thread (a process killed mid-plan leaves every finished
stage), float clouds uncompressed (zstd saves under 1 % on them and costs
milliseconds a megabyte), the others zstd; then, on the writer thread, the Foxglove
views (:mod:`._views`, of the arrays as recorded), ``run_end`` and the summary.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator, Sequence
from contextlib import contextmanager, suppress
from dataclasses import fields
from datetime import datetime, timezone
from pathlib import Path
from typing import IO, TYPE_CHECKING, Any

from mcap.writer import CompressionType, Writer

from wsgrasp.errors import RecordingError
from wsgrasp.perception.bag import is_mcap
from wsgrasp.record import _views, _worker
from wsgrasp.record._codec import (
    DESCRIPTOR_SET,
    FORMAT_VERSION,
    PROFILE,
    SCHEMA_NAME,
    TOPICS,
    encode,
)
from wsgrasp.record._runinfo import gripper_attachments, run_info
from wsgrasp.record._worker import wait_for_recorders

if TYPE_CHECKING:
    from wsgrasp.gripper.model import GripperModel
    from wsgrasp.perception.types import Scene
    from wsgrasp.planning.result import PlanResult
    from wsgrasp.spec import PipelineSpec

__all__ = ["RunRecorder", "check_record_path", "default_run_path", "wait_for_recorders"]

#: Full-fidelity channels that are mostly float clouds: stored uncompressed.
RAW_TOPICS = {TOPICS["inputs"], TOPICS["preprocess"], TOPICS["segmentation"]}
RAW, ZSTD = CompressionType.NONE, CompressionType.ZSTD


def default_run_path(
    spec: PipelineSpec, gripper_name: str, *, now: datetime | None = None
) -> Path:
    """``<spec.record.dir>/<UTC time to the microsecond>-<gripper>.mcap``."""
    t = (now or datetime.now(timezone.utc)).astimezone(timezone.utc)
    stamp = t.strftime("%Y%m%dT%H%M%S.%fZ")
    safe = "".join(c if c.isalnum() or c in "-_." else "_" for c in gripper_name)
    return Path(spec.record.dir) / f"{stamp}-{safe or 'gripper'}.mcap"


def _refused(p: Path, why: str, hint: str) -> RecordingError:
    return RecordingError(f"{p}: {why}", hint=hint)


_EXISTS = "a recording already exists there; wsgrasp never overwrites one"
_EXISTS_HINT = "choose another path, or pass --force to replace it"


def check_record_path(
    path: str | Path, *, force: bool = False, inputs: Sequence[str | Path] = ()
) -> Path:
    """``path``, where a recording may be written: ``force`` replaces only an MCAP
    file that is not one of ``inputs``, never through a symbolic link.

    Raises
    ------
    RecordingError
        ``path`` exists (and ``force`` is False), is a directory, a symbolic
        link, an input of the run, or a file that is not a recording.
    """
    p = Path(path)
    if p.is_symlink():
        why = "is a symbolic link; wsgrasp writes recordings to plain files only"
        raise _refused(p, why, "give the path it points to, or another path")
    if p.is_dir():
        why = "is a directory, not a recording file"
        raise _refused(p, why, "give a file path ending in .mcap")
    if not p.exists():
        return p
    if any(Path(s).exists() and p.samefile(s) for s in inputs):
        why = "is an input of this run; wsgrasp never records over its input"
        raise _refused(p, why, "choose another path for the recording")
    if not force:
        raise _refused(p, _EXISTS, _EXISTS_HINT)
    if not is_mcap(p):
        why = "exists and is not an MCAP recording; --force replaces recordings only"
        raise _refused(p, why, "choose another path, or remove the file yourself")
    return p


class RunRecorder:
    """Record one plan to an MCAP file; pass it to ``Pipeline.plan(observers=...)``.

    ``path`` is checked here, before the plan starts (:func:`check_record_path`).
    ``overhead_ms`` is the time the planner's thread spent in the recorder,
    ``views_ms`` and ``finish_ms`` the writer thread's (building the views, and
    finishing the file, views included).
    """

    def __init__(self, path: str | Path, *, force: bool = False) -> None:
        self.path = check_record_path(path, force=force)
        self.force = force
        self.overhead_ms = self.views_ms = self.finish_ms = 0.0
        self._writer: Writer | None = None
        self._stream: IO[bytes] | None = None
        self._schemas: dict[str, int] = {}
        self._channels: dict[str, int] = {}
        self._gripper: GripperModel | None = None
        self._table_axes = (0.0, 0.0, 0.0)
        self._candidates: Any = None
        self._stages_written: list[str] = []
        # (stage, what the record holds, t_ns) for the views, and the records'
        # bytes: the writer thread frees them (megabytes: milliseconds)
        self._recorded: list[tuple[str, Any, int]] = []
        self._written: list[bytes] = []
        self._finished = False  # no more hooks taken
        self._done: threading.Event | None = None  # set when the file is finished
        self._error: BaseException | None = None  # a failure on the writer thread
        _worker.start()  # now, not in the plan's time

    # -- PlanObserver ------------------------------------------------------------
    def on_start(self, spec: PipelineSpec, gripper: GripperModel, scene: Scene) -> None:
        """Write the run's versions and spec, the gripper model and the inputs."""
        wait_for_recorders()  # earlier runs' views: not while this one plans
        with self._writing():
            a, b, c = spec.table.semi_axes  # for the views, as the spec is now
            self._table_axes = (float(a), float(b), float(c))
            self._gripper = gripper
            self._open()
            now = time.time_ns()
            info = run_info(spec, gripper)
            for name, part in info.items():
                self._w.add_metadata(name, part)
            for name, media, data in gripper_attachments(spec, gripper):
                self._w.add_attachment(now, now, name, media, data)
            self._record("run", info, now)
            views = [
                {"name": v.name, "points": v.points, "T_world_camera": v.T_world_camera}
                for v in scene.views
            ]
            inputs = {
                "views": views,
                "points": scene.points,
                "dropped_nonfinite": int(scene.dropped_nonfinite),
                "dropped_no_depth": int(scene.dropped_no_depth),
            }
            self._record("inputs", inputs, now)

    def on_stage(self, stage: str, data: dict[str, Any]) -> None:
        """Write one stage's record."""
        if self._writer is None or self._finished:
            return
        with self._writing():
            self._record(stage, data, time.time_ns())
        if stage == "candidates":
            self._candidates = data.get("candidates")
        self._stages_written.append(stage)

    def on_result(self, result: PlanResult) -> None:
        """Write the result; the writer thread finishes the file."""
        record = {f.name: getattr(result, f.name) for f in fields(result)}
        if result.candidates is self._candidates and self._candidates is not None:
            record["candidates"] = "stage:candidates"  # the same, already recorded
        self._last("result", record, "ok")

    def on_error(self, error: BaseException) -> None:
        """Write what stopped the plan; the writer thread finishes the file."""
        record = {
            "type": getattr(error, "type_name", None) or type(error).__name__,
            "message": getattr(error, "message", str(error)),
            "hint": getattr(error, "hint", None),
            "stages": list(self._stages_written),
        }
        self._last("error", record, "error")

    def _last(self, stage: str, record: dict[str, Any], status: str) -> None:
        if self._writer is None or self._finished:
            return
        with self._writing():
            self._record(stage, record, time.time_ns())
            self._finish_later(status)

    def close(self) -> None:
        """Finish the file (also when the plan reported no result or error) and
        wait for it; safe to call twice.

        Raises
        ------
        RecordingError
            Writing the views or the file's end failed (the records are written).
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
    def _w(self) -> Writer:
        assert self._writer is not None
        return self._writer

    def _record(self, stage: str, value: Any, t_ns: int) -> None:
        """Write one record as a chunk of its own."""
        topic = TOPICS.get(stage, f"/wsgrasp/stage/{stage}")
        data, held = encode(value, topic.removeprefix("/wsgrasp/"))
        self._put(topic, data, t_ns)
        self._flush(RAW if topic in RAW_TOPICS else ZSTD)
        self._recorded.append((stage, held, t_ns))
        self._written.append(data)

    def _flush(self, compression: CompressionType) -> None:
        """End the chunk, compressed with ``compression`` (the Writer has one
        setting for all chunks; a test checks each gets its own)."""
        setattr(self._w, "_Writer__compression", compression)  # noqa: B010
        self._w.flush()

    @contextmanager
    def _writing(self) -> Iterator[None]:
        """Count the time as ``overhead_ms``; a failed write (disk full) is one
        ``RecordingError``, after which nothing more is written."""
        t0 = time.perf_counter()
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
        finally:
            self.overhead_ms += (time.perf_counter() - t0) * 1e3

    def _close_stream(self) -> None:
        with _worker.REGISTRY:
            _worker.OPEN.discard(self)
        if self._stream is not None:
            with suppress(OSError):
                self._stream.close()

    def _finish_later(self, status: str) -> None:
        """Hand the views and the file's end to the writer thread."""
        self._finished = True
        done = self._done = threading.Event()
        with _worker.REGISTRY:
            _worker.PENDING.add(self)

        def job() -> None:
            t0 = time.perf_counter()
            try:
                self._write_views()
                self._finish(status)
            except BaseException as exc:  # noqa: BLE001 - raised by close()
                self._error = exc
            finally:
                self._close_stream()
                self._recorded.clear()  # the records' buffers freed here, too
                self._written.clear()
                self.finish_ms += (time.perf_counter() - t0) * 1e3
                with _worker.REGISTRY:
                    _worker.PENDING.discard(self)
                done.set()

        _worker.submit(job)

    def _write_views(self) -> None:
        """Every stage's views: clouds in one uncompressed chunk, the rest zstd. A
        view that fails is a warning."""
        t0 = time.perf_counter()
        clouds: list[Any] = []
        rest: list[Any] = []
        for stage, held, t in self._recorded:
            try:
                assert self._gripper is not None  # set in on_start
                views = _views.views_of(stage, held, t, self._gripper, self._table_axes)
            except Exception as exc:  # noqa: BLE001 - views are a convenience
                warning, _ = encode({"stage": stage, "error": repr(exc)}, "warnings")
                rest.append(("/wsgrasp/warnings", warning, t, None))
                continue
            for topic, msg in views:
                row = (topic, msg.encode(), t, type(msg))
                (clouds if isinstance(msg, _views.fm.PointCloud) else rest).append(row)
        self.views_ms += (time.perf_counter() - t0) * 1e3
        for rows, compression in ((clouds, RAW), (rest, ZSTD)):
            for row in rows:
                self._put(*row)
            self._flush(compression)

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
            raise _refused(self.path, _EXISTS, _EXISTS_HINT) from None
        except OSError as exc:
            raise RecordingError(
                f"{self.path}: cannot create the recording: {exc.strerror}",
                hint="check the directory exists and is writable, or use --no-record",
            ) from None
        self._stream = raw
        from wsgrasp._version import __version__

        # chunks end only where _flush ends them: one (or two) per stage
        self._writer = Writer(raw, chunk_size=1 << 62)
        self._writer.start(profile=PROFILE, library=f"wsgrasp {__version__}")
        with _worker.REGISTRY:
            _worker.OPEN.add(self)

    def _finish(self, status: str) -> None:
        end = {
            "status": status,
            "stages": ",".join(self._stages_written),
            "finished_utc": datetime.now(timezone.utc).isoformat(),
            "recorder_ms": f"{self.overhead_ms:.3f}",
            "views_ms": f"{self.views_ms:.3f}",
        }
        self._w.add_metadata("run_end", end)
        self._w.finish()

    def _put(self, topic: str, data: bytes, t: int, kind: Any = None) -> None:
        """Add a ``wsgrasp.Record``, or a message of foxglove-sdk's class ``kind``."""
        cid = self._channels.get(topic)
        if cid is None:
            schema = None if kind is None else kind.get_schema()
            name = SCHEMA_NAME if schema is None else schema.name
            if name not in self._schemas:
                described = DESCRIPTOR_SET if schema is None else bytes(schema.data)
                sid = self._w.register_schema(name, "protobuf", described)
                self._schemas[name] = sid
            meta = {"wsgrasp_format": str(FORMAT_VERSION)}
            cid = self._w.register_channel(topic, "protobuf", self._schemas[name], meta)
            self._channels[topic] = cid
        self._w.add_message(cid, log_time=t, data=data, publish_time=t)
