"""Reading a recorded run back: :func:`open_run`.

The file is read with mcap's ``StreamReader``, record by record, the CRCs of
chunks and attachments checked (the latter here: the reader skips them). A file
cut short (a crash), which ``make_reader`` refuses for lack of a summary, is read
up to the cut, where the stream reader fails as on a damaged record; so the record
where it stopped is looked at: one that runs past the end of the file is a cut
(the run is read up to its last complete record and marked truncated), anything
else corruption. Corruption, a file that is not MCAP or not a wsgrasp run, and a
newer format are each one :class:`~wsgrasp.errors.RecordingError`.
"""

from __future__ import annotations

import zlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any

from mcap.opcode import Opcode
from mcap.records import Attachment, Channel, Footer, Header, Message, Metadata, Schema
from mcap.stream_reader import StreamReader
from mcap.writer import MCAP0_MAGIC

from wsgrasp.errors import RecordingError
from wsgrasp.record._codec import FORMAT_VERSION, PROFILE, SCHEMA_NAME, TOPICS, loads
from wsgrasp.record._run import PARTS, RawMessage, Run
from wsgrasp.record._worker import wait_for_recorders

__all__ = ["open_run"]


@dataclass
class _Scan:
    """The complete records of a file, and where it stops if it is cut."""

    header: Header | None = None
    schemas: dict[int, Schema] = field(default_factory=dict)
    channels: dict[int, Channel] = field(default_factory=dict)
    messages: list[RawMessage] = field(default_factory=list)
    metadata: dict[str, dict[str, str]] = field(default_factory=dict)
    attachments: dict[str, bytes] = field(default_factory=dict)
    footer: bool = False
    truncated_at: int | None = None

    def add(self, rec: Any) -> None:
        match rec:
            case Header():
                self.header = rec
            case Schema():
                self.schemas[rec.id] = rec
            case Channel():
                self.channels[rec.id] = rec
            case Message():
                ch = self.channels.get(rec.channel_id)
                if ch is None:
                    raise ValueError(f"message on unknown channel {rec.channel_id}")
                sc = self.schemas.get(ch.schema_id) or _NO_SCHEMA
                raw = (sc.name, sc.encoding, sc.data, ch.message_encoding)
                self.messages.append(RawMessage(ch.topic, *raw, rec.log_time, rec.data))
            case Metadata():
                self.metadata[rec.name] = dict(rec.metadata)
            case Attachment():
                self.attachments[rec.name] = rec.data
            case Footer():
                self.footer = True


_NO_SCHEMA = Schema(id=0, data=b"", encoding="", name="")


def _corrupt(path: Path, offset: int, what: str) -> RecordingError:
    return RecordingError(
        f"{path}: corrupt MCAP file at byte {offset}: {what}",
        hint="the file was damaged after it was written; use another copy of the run",
    )


def _scan(path: Path, fh: IO[bytes], size: int) -> _Scan:
    """Every complete record of the file; where it stops, if it is cut."""
    head = fh.read(len(MCAP0_MAGIC))
    if not MCAP0_MAGIC.startswith(head):
        raise RecordingError(
            f"{path}: not an MCAP file (it starts with {head!r}, MCAP files "
            f"start with {MCAP0_MAGIC!r})",
            hint="give a run recorded by `wsgrasp plan` (runs/*.mcap)",
        )
    fh.seek(0)
    scan = _Scan()
    pos = 0  # the end of the last complete record
    try:
        for rec in StreamReader(fh, validate_crcs=True).records:
            if isinstance(rec, Attachment):
                _check_attachment(path, fh, pos, rec.name)
            scan.add(rec)
            pos = fh.tell()
    except RecordingError:
        raise
    except Exception as exc:  # noqa: BLE001 - any failure: a cut or damage
        if not _runs_past_the_end(fh, pos, size):
            raise _corrupt(path, pos, f"{type(exc).__name__}: {exc}") from None
        scan.truncated_at = pos
    return scan


def _check_attachment(path: Path, fh: IO[bytes], start: int, name: str) -> None:
    """Compare the CRC closing the attachment record that ends here (mcap's reader
    skips it) with the CRC of the record's fields before it; ``start``: where the
    record before it ended (unless a record mcap does not know came between)."""
    end = fh.tell()
    fh.seek(start)
    opcode, length = fh.read(1), int.from_bytes(fh.read(8), "little")
    if opcode == bytes([Opcode.ATTACHMENT]) and start + 9 + length == end:
        body, crc = fh.read(length - 4), int.from_bytes(fh.read(4), "little")
        if crc != 0 and zlib.crc32(body) != crc:
            raise _corrupt(path, start, f"attachment {name!r} fails its CRC")
    fh.seek(end)


def _runs_past_the_end(fh: IO[bytes], pos: int, size: int) -> bool:
    """Whether the record at ``pos`` (or the magic there) ends after ``size``
    bytes: an MCAP record starts with its opcode (1 byte) and length (8)."""
    if pos + 9 > size:
        return True
    fh.seek(pos + 1)
    return pos + 9 + int.from_bytes(fh.read(8), "little") > size


def open_run(path: str | Path) -> Run:
    """Read a run recorded by ``wsgrasp plan`` (a :class:`RunRecorder`): inputs,
    spec, gripper model, candidates and result; ``truncated`` and ``missing`` say
    whether the file stops early and what it lacks.

    Raises
    ------
    RecordingError
        The file is missing, not MCAP, corrupt (a changed byte in a record, the
        spec and versions included), not a wsgrasp run, or recorded in a newer
        format than this wsgrasp reads.
    """
    wait_for_recorders()  # a run this process is still finishing
    p = Path(path)
    if not p.is_file():
        raise RecordingError(
            f"{p}: no such run file" if not p.exists() else f"{p}: is not a file",
            hint="check the path; runs are recorded under runs/ by default",
        )
    try:
        size = p.stat().st_size
        if size == 0:
            raise RecordingError(
                f"{p}: the file is empty",
                hint="the run was not recorded (it stopped before its first write?)",
            )
        with open(p, "rb") as fh:
            scan = _scan(p, fh, size)
    except OSError as exc:
        raise RecordingError(f"{p}: cannot read: {exc.strerror}") from None
    return _run_from_scan(p, scan)


def _check_version(p: Path, scan: _Scan) -> tuple[int, str]:
    header, meta = scan.header, scan.metadata.get("wsgrasp")
    if not ((header is not None and header.profile == PROFILE) or meta is not None):
        if header is None:
            raise RecordingError(
                f"{p}: the file stops before its MCAP header; nothing was recorded",
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
    if not version_text.isdigit():
        raise _corrupt(p, 0, f"format_version {version_text!r} is not a number")
    version, recorded_by = int(version_text), (meta or {}).get("wsgrasp_version", "?")
    if version > FORMAT_VERSION:
        from wsgrasp._version import __version__

        raise RecordingError(
            f"{p}: was recorded by wsgrasp {recorded_by} in run format {version}; "
            f"this wsgrasp ({__version__}) reads run formats up to {FORMAT_VERSION}",
            hint=f"upgrade wsgrasp to {recorded_by} or newer (pip install -U wsgrasp)",
        )
    return version, recorded_by


def _run_from_scan(p: Path, scan: _Scan) -> Run:
    version, recorded_by = _check_version(p, scan)
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
    metadata = dict(scan.metadata)
    if version >= 3:  # the checked record is the run's metadata
        for name in ("wsgrasp", "spec", "plugins"):
            metadata.pop(name, None)
        for name, part in (by_topic.get(TOPICS["run"]) or {}).items():
            if scan.metadata.get(name, part) != part:
                why = f"metadata {name!r} differs from the run's checked record"
                raise _corrupt(p, 0, why)
            metadata[name] = part
    result_data = by_topic.get(TOPICS["result"])
    if result_data is not None and isinstance(result_data.get("candidates"), str):
        result_data["candidates"] = stages.get("candidates", {}).get("candidates")
    error = by_topic.get(TOPICS["error"])
    inputs = by_topic.get(TOPICS["inputs"])
    if inputs is not None and isinstance(inputs.get("points"), str):
        raise RecordingError(
            f"{p}: run format {version} stores the merged points as a rule "
            f"({inputs['points']!r}), made again by a merge that depends on the "
            "machine; this wsgrasp reads the points a run stores (format 3)",
            hint=f"read or replay it with wsgrasp {recorded_by}, which recorded it",
        )
    present = {
        "metadata": "wsgrasp" in metadata,
        "spec": "spec" in metadata,
        "inputs": inputs is not None,
        "gripper model": "gripper/model.npz" in scan.attachments,
        "result": result_data is not None,
        **{s: s in stages for s in PARTS[4:8]},
    }
    # a plan that stopped: the parts after the failure were never meant to exist
    missing = [] if error is not None else [s for s in PARTS if not present[s]]
    return Run(
        path=p,
        format_version=version,
        wsgrasp_version=recorded_by,
        metadata=metadata,
        attachments=scan.attachments,
        inputs=inputs,
        stages=stages,
        result_data=result_data,
        error=error,
        truncated=not scan.footer,
        truncated_at=scan.truncated_at,
        missing=missing,
        messages=scan.messages,
    )
