"""Reading a recorded run back: :func:`open_run`.

The file is read record by record. A file that stops early (a crash, a copy cut
short) is read up to its last complete record and marked truncated, with what is
missing; a file that is not MCAP, is MCAP but not a wsgrasp run, is corrupt, or was
written in a newer format gets one :class:`~wsgrasp.errors.RecordingError`.
"""

from __future__ import annotations

import json
import zlib
from dataclasses import dataclass, field, fields
from functools import cached_property
from io import BytesIO
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from mcap.data_stream import ReadDataStream
from mcap.opcode import Opcode
from mcap.records import (
    Attachment,
    Channel,
    Chunk,
    Footer,
    Header,
    Message,
    Metadata,
    Schema,
)
from mcap.stream_reader import breakup_chunk

from wsgrasp.errors import RecordingError
from wsgrasp.record._codec import FORMAT_VERSION, PROFILE, TOPICS, loads
from wsgrasp.record._proto import SCHEMA_NAME

if TYPE_CHECKING:
    from wsgrasp.gripper.model import GripperModel
    from wsgrasp.perception.types import Scene
    from wsgrasp.planning.result import CandidateSet, PlanResult
    from wsgrasp.spec import PipelineSpec

__all__ = ["Run", "RawMessage", "open_run", "PARTS"]

MAGIC = b"\x89MCAP0\r\n"

#: What a complete run holds, in the order it is written.
PARTS = (
    "metadata",
    "spec",
    "inputs",
    "gripper model",
    "preprocess",
    "segmentation",
    "object_frame",
    "candidates",
    "result",
)


@dataclass
class RawMessage:
    """One message as stored, with its channel's schema."""

    topic: str
    schema_name: str
    schema_encoding: str
    schema_data: bytes
    message_encoding: str
    log_time: int
    data: bytes


@dataclass
class Run:
    """A recorded run, as read by :func:`open_run`.

    Attributes
    ----------
    path : Path
    format_version : int
    wsgrasp_version : str
        Version of wsgrasp that recorded the run.
    metadata : dict of str to dict of str to str
        The MCAP metadata records by name (``wsgrasp``, ``spec``, ``plugins``,
        ``run_end``).
    attachments : dict of str to bytes
    inputs : dict or None
        The decoded inputs record (views, merged points).
    stages : dict of str to dict
        Each recorded stage's data (arrays exact; the candidates as a dict).
    result_data : dict or None
        The decoded result record.
    error : dict or None
        What stopped the plan (``type``, ``message``, ``hint``), if it failed.
    truncated : bool
        The file ends before its footer (e.g. the process crashed).
    truncated_at : int or None
        Byte offset of the first incomplete record.
    missing : list of str
        Parts of a complete run (:data:`PARTS`) this file lacks.
    messages : list of RawMessage
        Every message, in file order.
    """

    path: Path
    format_version: int
    wsgrasp_version: str
    metadata: dict[str, dict[str, str]]
    attachments: dict[str, bytes]
    inputs: dict[str, Any] | None
    stages: dict[str, dict[str, Any]]
    result_data: dict[str, Any] | None
    error: dict[str, Any] | None
    truncated: bool
    truncated_at: int | None
    missing: list[str]
    messages: list[RawMessage] = field(repr=False, default_factory=list)

    # -- typed views ----------------------------------------------------------------
    @property
    def status(self) -> str:
        """``"ok"`` (a result), ``"error"`` (the plan raised) or ``"truncated"``."""
        if self.result_data is not None:
            return "ok"
        if self.error is not None:
            return "error"
        return "truncated"

    @cached_property
    def spec_data(self) -> dict[str, Any] | None:
        """The resolved spec as plain data."""
        raw = self.metadata.get("spec", {}).get("json")
        return None if raw is None else json.loads(raw)

    @cached_property
    def spec(self) -> PipelineSpec:
        """The recorded spec (validated; plugins are not looked up).

        Raises
        ------
        RecordingError
            The file holds no spec, or it does not validate with this wsgrasp.
        """
        from wsgrasp.errors import SpecError
        from wsgrasp.spec import load_spec

        if self.spec_data is None:
            raise RecordingError(
                f"{self.path}: holds no spec (the file was cut before it)",
                hint="replay needs a run recorded at least up to its inputs",
            )
        try:
            return load_spec(self.spec_data, check_plugins=False)
        except SpecError as exc:
            raise RecordingError(
                f"{self.path}: the recorded spec does not validate with this "
                f"wsgrasp: {exc.message}",
                hint=f"use wsgrasp {self.wsgrasp_version}, which recorded it",
            ) from None

    @property
    def plugins(self) -> list[dict[str, Any]]:
        """Every plugin loaded when the run was recorded (distribution, version)."""
        out = []
        for key, raw in sorted(self.metadata.get("plugins", {}).items()):
            try:
                out.append(json.loads(raw))
            except ValueError:
                out.append({"name": key, "error": raw})
        return out

    @cached_property
    def gripper(self) -> GripperModel:
        """The gripper model from the attachment (no plugin needed).

        Raises
        ------
        RecordingError
            The file holds no gripper model.
        """
        from wsgrasp.errors import GripperError
        from wsgrasp.gripper.model import GripperModel

        data = self.attachments.get("gripper/model.npz")
        if data is None:
            raise RecordingError(
                f"{self.path}: holds no gripper model"
                + (" (the file is truncated)" if self.truncated else ""),
                hint="replay needs a run recorded at least up to its inputs",
            )
        try:
            return GripperModel.from_bytes(data)
        except GripperError as exc:
            raise RecordingError(
                f"{self.path}: the recorded gripper model is unreadable: {exc.message}"
            ) from None

    @cached_property
    def scene(self) -> Scene:
        """The planner's input, bit for bit.

        Raises
        ------
        RecordingError
            The file holds no inputs.
        """
        from wsgrasp.perception.types import Scene, View

        if self.inputs is None:
            raise RecordingError(
                f"{self.path}: holds no inputs (the file was cut before them)",
                hint="nothing of this run can be replayed",
            )
        d = self.inputs
        if d.get("points_mismatch"):
            raise RecordingError(
                f"{self.path}: {d['points_mismatch']}",
                hint="replay the run where it was recorded (same numpy and BLAS)",
            )
        views = [
            View(points=v["points"], T_world_camera=v["T_world_camera"], name=v["name"])
            for v in d["views"]
        ]
        return Scene(
            views=views,
            points=d["points"],
            dropped_nonfinite=int(d.get("dropped_nonfinite", 0)),
        )

    @cached_property
    def candidates(self) -> CandidateSet | None:
        """Every candidate evaluated, or None if the file stops before them."""
        if self.result_data is not None:
            cs = self.result_data.get("candidates")
            if isinstance(cs, dict):
                return _candidate_set(cs)
        stage = self.stages.get("candidates")
        if stage is not None and isinstance(stage.get("candidates"), dict):
            return _candidate_set(stage["candidates"])
        return None

    @cached_property
    def result(self) -> PlanResult | None:
        """The plan's result, or None if the plan failed or the file stops early."""
        from wsgrasp.planning.result import (
            Alternative,
            CandidateSet,
            Contact,
            PlanResult,
        )

        if self.result_data is None:
            return None
        d = dict(self.result_data)
        cs = self.candidates
        d["candidates"] = cs if cs is not None else _empty_candidates(CandidateSet)
        d["contacts"] = [Contact(**_known(Contact, c)) for c in d.get("contacts", [])]
        d["alternatives"] = [
            Alternative(**_known(Alternative, a)) for a in d.get("alternatives", [])
        ]
        try:
            return PlanResult(**_known(PlanResult, d))
        except TypeError as exc:
            raise RecordingError(
                f"{self.path}: the recorded result does not fit this wsgrasp: {exc}",
                hint=f"use wsgrasp {self.wsgrasp_version}, which recorded it",
            ) from None

    @property
    def timing_ms(self) -> dict[str, float]:
        """The plan's stage timings, the recorder's time in the plan
        (``recorder``) and, after it, building the Foxglove views (``views``)."""
        out: dict[str, float] = {}
        if self.result_data is not None:
            out.update(
                {k: float(v) for k, v in self.result_data.get("timing_ms", {}).items()}
            )
        end = self.metadata.get("run_end", {})
        for key, name in (("recorder_ms", "recorder"), ("views_ms", "views")):
            if end.get(key) is not None:
                out[name] = float(end[key])
        return out

    def topics(self) -> dict[str, tuple[str, int]]:
        """Topic → (schema name, message count)."""
        out: dict[str, tuple[str, int]] = {}
        for m in self.messages:
            name, n = out.get(m.topic, (m.schema_name, 0))
            out[m.topic] = (name, n + 1)
        return out


def _known(cls: Any, d: dict[str, Any]) -> dict[str, Any]:
    names = {f.name for f in fields(cls)}
    return {k: v for k, v in d.items() if k in names}


def _candidate_set(d: dict[str, Any]) -> CandidateSet:
    from wsgrasp.planning.result import CandidateSet

    d = _known(CandidateSet, d)
    d["terms"] = dict(d.get("terms") or {})
    return CandidateSet(**d)


def _empty_candidates(cls: Any) -> CandidateSet:
    z = np.zeros((0, 4, 4))
    e = np.zeros(0)
    i = np.zeros(0, dtype=np.int64)
    return cls(z, z.copy(), i, e, i.copy(), np.zeros((0, 0), np.int64), e.copy())


# -- the file ------------------------------------------------------------------------
_KNOWN_OPCODES = {int(o) for o in Opcode}


@dataclass
class _Scan:
    header: Header | None = None
    schemas: dict[int, Schema] = field(default_factory=dict)
    channels: dict[int, Channel] = field(default_factory=dict)
    messages: list[RawMessage] = field(default_factory=list)
    metadata: dict[str, dict[str, str]] = field(default_factory=dict)
    attachments: dict[str, bytes] = field(default_factory=dict)
    footer: bool = False
    truncated_at: int | None = None


def _records(path: Path, data: bytes) -> _Scan:
    """Split ``data`` into MCAP records; stop at the first incomplete one."""
    if len(data) == 0:
        raise RecordingError(
            f"{path}: the file is empty",
            hint="the run was not recorded (it stopped before its first write?)",
        )
    if not data.startswith(MAGIC[: min(len(data), len(MAGIC))]):
        raise RecordingError(
            f"{path}: not an MCAP file (it starts with {data[:8]!r}, MCAP files "
            f"start with {MAGIC!r})",
            hint="give a run recorded by `wsgrasp plan` (runs/*.mcap)",
        )
    scan = _Scan()
    pos = len(MAGIC)
    if len(data) < pos:
        scan.truncated_at = 0
        return scan
    while pos < len(data):
        if pos + 9 > len(data):
            scan.truncated_at = pos
            break
        opcode = data[pos]
        length = int.from_bytes(data[pos + 1 : pos + 9], "little")
        end = pos + 9 + length
        if opcode not in _KNOWN_OPCODES:
            raise _corrupt(path, pos, f"unknown record type 0x{opcode:02x}")
        if end > len(data):
            scan.truncated_at = pos
            break
        body = data[pos + 9 : end]
        try:
            _record(scan, opcode, body)
        except RecordingError:
            raise
        except Exception as exc:  # noqa: BLE001 - any decoding failure
            raise _corrupt(path, pos, f"{Opcode(opcode).name} record: {exc}") from None
        if opcode == Opcode.FOOTER:
            scan.footer = True
            if data[end : end + len(MAGIC)] != MAGIC:
                raise _corrupt(path, end, "no closing magic after the footer")
            break
        pos = end
    else:
        scan.truncated_at = pos
    return scan


def _corrupt(path: Path, offset: int, what: str) -> RecordingError:
    return RecordingError(
        f"{path}: corrupt MCAP file at byte {offset}: {what}",
        hint="the file was damaged after it was written; use another copy of the run",
    )


def _record(scan: _Scan, opcode: int, body: bytes) -> None:
    stream = ReadDataStream(BytesIO(body))
    if opcode == Opcode.HEADER:
        scan.header = Header.read(stream)
    elif opcode == Opcode.SCHEMA:
        _add(scan, Schema.read(stream))
    elif opcode == Opcode.CHANNEL:
        _add(scan, Channel.read(stream))
    elif opcode == Opcode.MESSAGE:
        _add(scan, Message.read(stream, len(body)))
    elif opcode == Opcode.CHUNK:
        for rec in breakup_chunk(Chunk.read(stream), validate_crc=True):
            _add(scan, rec)
    elif opcode == Opcode.METADATA:
        meta = Metadata.read(stream)
        scan.metadata[meta.name] = dict(meta.metadata)
    elif opcode == Opcode.ATTACHMENT:
        att = Attachment.read(stream)
        crc = int.from_bytes(body[-4:], "little")
        if crc != 0 and zlib.crc32(body[:-4]) != crc:
            raise ValueError(f"attachment {att.name!r} fails its CRC check")
        scan.attachments[att.name] = att.data
    elif opcode == Opcode.FOOTER:
        Footer.read(stream)


def _add(scan: _Scan, rec: Any) -> None:
    if isinstance(rec, Schema):
        scan.schemas[rec.id] = rec
    elif isinstance(rec, Channel):
        scan.channels[rec.id] = rec
    elif isinstance(rec, Message):
        ch = scan.channels.get(rec.channel_id)
        if ch is None:
            raise ValueError(f"message on unknown channel {rec.channel_id}")
        sc = scan.schemas.get(ch.schema_id)
        scan.messages.append(
            RawMessage(
                topic=ch.topic,
                schema_name="" if sc is None else sc.name,
                schema_encoding="" if sc is None else sc.encoding,
                schema_data=b"" if sc is None else sc.data,
                message_encoding=ch.message_encoding,
                log_time=rec.log_time,
                data=rec.data,
            )
        )


def _rebuild_points(inputs: dict[str, Any]) -> None:
    """Put the merged scene points back into ``inputs`` when the file stores how to
    make them rather than them (see :func:`wsgrasp.record._writer._inputs_record`).

    When this machine's merge does not give the recorded check value (another
    numpy or BLAS than the recording machine's), ``points`` is still the merge and
    ``points_mismatch`` says so; :attr:`Run.scene` then refuses to pass it off as
    the planner's input.
    """
    from wsgrasp.record._writer import MERGED, merge_views, points_check

    rule = inputs["points"]
    views = inputs.get("views") or []
    if rule == "views[0].points" and views:  # format 1
        inputs["points"] = views[0]["points"]
        return
    if rule != MERGED or not views:
        raise ValueError(f"unknown rule for the merged points: {rule!r}")
    merged = merge_views([(v["points"], v["T_world_camera"]) for v in views])
    inputs["points"] = merged
    want = inputs.get("points_check")
    if want is not None and points_check(merged) != want:
        inputs["points_mismatch"] = (
            "the recording stores the merged scene points as the merge of its "
            "views, and merging them here does not give the recorded bits "
            f"(check value {points_check(merged)}, recorded {want}); this "
            "machine's numpy/BLAS computes the merge differently"
        )


def open_run(path: str | Path) -> Run:
    """Read a recorded run.

    Parameters
    ----------
    path
        A ``.mcap`` file written by ``wsgrasp plan`` (or :class:`RunRecorder`).

    Returns
    -------
    Run
        Inputs, spec, gripper model, candidates and result; ``truncated`` and
        ``missing`` say whether the file stops early and what it lacks.

    Raises
    ------
    RecordingError
        The file is missing, not MCAP, corrupt, not a wsgrasp run, or recorded in a
        newer format than this wsgrasp reads.
    """
    from wsgrasp.record._writer import wait_for_recorders

    wait_for_recorders()  # a run this process is still finishing
    p = Path(path)
    if not p.is_file():
        raise RecordingError(
            f"{p}: no such run file" if not p.exists() else f"{p}: is not a file",
            hint="check the path; runs are recorded under runs/ by default",
        )
    try:
        data = p.read_bytes()
    except OSError as exc:
        raise RecordingError(f"{p}: cannot read: {exc.strerror}") from None
    scan = _records(p, data)
    return _run_from_scan(p, scan)


def _run_from_scan(p: Path, scan: _Scan) -> Run:
    header = scan.header
    meta = scan.metadata.get("wsgrasp")
    is_ours = (header is not None and header.profile == PROFILE) or meta is not None
    if not is_ours:
        if header is None:
            raise RecordingError(
                f"{p}: the file stops before its MCAP header "
                f"({len(MAGIC) if scan.truncated_at is None else scan.truncated_at} "
                "bytes); nothing was recorded",
                hint="the run crashed as it started; plan again",
            )
        topics = sorted({m.topic for m in scan.messages})
        shown = ", ".join(topics[:8]) + (" ..." if len(topics) > 8 else "")
        raise RecordingError(
            f"{p}: is an MCAP file but not a wsgrasp run (profile "
            f"{header.profile!r}, written by {header.library!r}"
            + (f"; topics: {shown}" if topics else "")
            + ")",
            hint="inspect/replay/view take runs recorded by `wsgrasp plan`; to plan "
            "on a ROS 2 bag use `wsgrasp plan BAG --topic TOPIC`",
        )
    version_text = (meta or {}).get("format_version", str(FORMAT_VERSION))
    try:
        version = int(version_text)
    except ValueError:
        raise _corrupt(
            p, 0, f"format_version {version_text!r} is not a number"
        ) from None
    recorded_by = (meta or {}).get("wsgrasp_version", "unknown")
    if version > FORMAT_VERSION:
        from wsgrasp import __version__

        raise RecordingError(
            f"{p}: was recorded by wsgrasp {recorded_by} in run format {version}; "
            f"this wsgrasp ({__version__}) reads run formats up to {FORMAT_VERSION}",
            hint=f"upgrade wsgrasp to {recorded_by} or newer (pip install -U wsgrasp)",
        )

    by_topic: dict[str, Any] = {}
    stages: dict[str, dict[str, Any]] = {}
    for m in scan.messages:
        if m.topic.startswith("/wsgrasp/") and m.schema_name == SCHEMA_NAME:
            try:
                value = loads(m.data)
            except Exception as exc:  # noqa: BLE001 - any decoding failure
                raise RecordingError(
                    f"{p}: message on {m.topic} does not decode: {exc}",
                    hint="the file was damaged; use another copy of the run",
                ) from None
            by_topic[m.topic] = value
            if m.topic.startswith("/wsgrasp/stage/"):
                stages[m.topic.removeprefix("/wsgrasp/stage/")] = value
    result_data = by_topic.get(TOPICS["result"])
    if result_data is not None and isinstance(result_data.get("candidates"), str):
        stage = stages.get("candidates", {})
        result_data["candidates"] = stage.get("candidates")
    error = by_topic.get(TOPICS["error"])
    inputs = by_topic.get(TOPICS["inputs"])
    if inputs is not None and isinstance(inputs.get("points"), str):
        try:
            _rebuild_points(inputs)
        except (ValueError, KeyError, TypeError) as exc:
            raise _corrupt(p, 0, f"the inputs record: {exc}") from None

    truncated = not scan.footer
    present = {
        "metadata": meta is not None,
        "spec": "spec" in scan.metadata,
        "inputs": inputs is not None,
        "gripper model": "gripper/model.npz" in scan.attachments,
        "result": result_data is not None,
        **{s: s in stages for s in PARTS[4:8]},
    }
    if error is not None:
        # the plan stopped; the parts after the failure were never meant to exist
        missing = []
    else:
        missing = [part for part in PARTS if not present[part]]
    return Run(
        path=p,
        format_version=version,
        wsgrasp_version=recorded_by,
        metadata=scan.metadata,
        attachments=scan.attachments,
        inputs=inputs,
        stages=stages,
        result_data=result_data,
        error=error,
        truncated=truncated,
        truncated_at=scan.truncated_at,
        missing=missing,
        messages=scan.messages,
    )
