"""A small chunked MCAP writer that picks the zstd level per chunk.

``mcap.writer.Writer`` compresses every chunk at zstd's default level, which costs
~3 ms per MB on the float arrays a run is mostly made of, and gains nothing on them
(noisy float64 does not compress). This writer ends a chunk only when asked
(``flush``), compresses small structured chunks at level 3 and larger ones at
fast levels (see ``_LEVELS``), and otherwise writes the same records, indexes and
summary as ``mcap.writer.Writer`` (it builds them with ``mcap.records``).

A chunk that zstd cannot shrink (float32 sensor clouds are noise to it: level -7
saves 0.003 % on them) is written as a zstd frame of raw blocks, built here
(RFC 8878, 3.1.1): the same bytes zstd would write for it, without compressing,
joining or copying the pieces first. Every chunk is a zstd chunk either way; any
zstd decoder reads both.
"""

from __future__ import annotations

import os
import struct
import threading
import zlib
from collections import defaultdict
from collections.abc import Sequence
from typing import IO

import xxhash
import zstandard
from mcap.data_stream import RecordBuilder
from mcap.opcode import Opcode
from mcap.records import (
    Attachment,
    AttachmentIndex,
    ChunkIndex,
    DataEnd,
    Footer,
    Header,
    MessageIndex,
    Metadata,
    MetadataIndex,
    Statistics,
    SummaryOffset,
)

__all__ = ["ChunkWriter"]

_MESSAGE = struct.Struct("<BQHIQQ")
_CHUNK = struct.Struct("<BQQQQII4sQ")

MAGIC = b"\x89MCAP0\r\n"
#: zstd level by chunk size: structured chunks (up to 64 KiB) at 3; float arrays
#: at 1 (level 3 saves ~15 % more on float64 but takes 3-4 times as long); large
#: chunks, mostly raw float32 clouds that hardly compress, at -1
_LEVELS = ((64 * 1024, 3), (512 * 1024, 1))
_LEVEL_LARGE = -1
#: ``flush(fast=True)``: chunks over 64 KiB at -7, which stores float arrays that
#: do not compress (most) as they are in a tenth of level 1's time and still
#: compresses candidate records ~10x
_LEVEL_FAST = -7
#: ``flush(fast=True)``: chunks up to 64 KiB at 1 (level 3 takes twice as long for
#: a few per cent)
_LEVEL_FAST_SMALL = 1
#: chunks larger than this are checked by zstd's checksum, not the chunk CRC
_FAST_ABOVE = 512 * 1024


#: a chunk at least this large is probed (:func:`_incompressible`) and, when
#: zstd would not shrink it, written as raw blocks
_RAW_ABOVE = 64 * 1024
#: the probe: this many evenly spaced slices of this many bytes, compressed at
#: ``_LEVEL_FAST``; raw when they shrink by less than ``1 - _RAW_RATIO``
_PROBES, _PROBE_BYTES, _RAW_RATIO = 4, 8192, 0.97
#: zstd frame: magic; descriptor 0xE4 (8-byte content size, single segment,
#: content checksum, no dictionary); a block holds at most 128 KiB
_ZSTD_MAGIC = b"\x28\xb5\x2f\xfd"
_ZSTD_RAW_DESCRIPTOR = b"\xe4"
_ZSTD_BLOCK_MAX = 128 * 1024
#: parts up to this size are joined into one block (a block header is 3 bytes)
_SMALL_PART = 4096


#: writes of at least this many bytes go to the file with one ``os.writev``
_WRITEV_ABOVE = 64 * 1024
#: pieces per ``os.writev`` call (the system's limit, usually 1024)
_IOV_MAX = max(
    16, min(os.sysconf("SC_IOV_MAX") if hasattr(os, "sysconf") else 16, 1024)
)

_COMPRESSORS = threading.local()


def _compressor(level: int, checksum: bool) -> zstandard.ZstdCompressor:
    """A zstd compressor, made once per thread and setting (making one costs
    tens of microseconds; one may not be used by two threads at once)."""
    cache = getattr(_COMPRESSORS, "cache", None)
    if cache is None:
        cache = _COMPRESSORS.cache = {}
    key = (level, checksum)
    z = cache.get(key)
    if z is None:
        z = cache[key] = zstandard.ZstdCompressor(level=level, write_checksum=checksum)
    return z


def _sample(parts: Sequence[bytes | memoryview], size: int) -> bytes:
    """:data:`_PROBES` slices of :data:`_PROBE_BYTES`, evenly spaced over the
    concatenation of ``parts`` (``size`` bytes in all)."""
    out: list[bytes] = []
    step = size // _PROBES
    starts = [i * step for i in range(_PROBES)]
    offset, k = 0, 0
    for part in parts:
        n = len(part)
        while k < len(starts) and starts[k] < offset + n:
            lo = starts[k] - offset
            out.append(bytes(memoryview(part)[lo : lo + _PROBE_BYTES]))
            k += 1
        offset += n
    return b"".join(out)


def _incompressible(parts: Sequence[bytes | memoryview], size: int) -> bool:
    """Whether zstd would leave these bytes (almost) as they are, judged on
    samples (microseconds)."""
    sample = _sample(parts, size)
    packed = _compressor(_LEVEL_FAST, False).compress(sample)
    return len(packed) >= _RAW_RATIO * len(sample)


def raw_zstd_frame(
    parts: Sequence[bytes | memoryview], size: int
) -> list[bytes | memoryview]:
    """A zstd frame of raw blocks holding the concatenation of ``parts``
    (``size`` bytes), in pieces: small parts are joined, large ones are sliced
    into blocks (views, not copies). The frame ends with zstd's content checksum
    (the low 32 bits of the content's XXH64, which every zstd decoder checks):
    three times cheaper than the chunk's CRC-32."""
    out: list[bytes | memoryview] = [
        _ZSTD_MAGIC,
        _ZSTD_RAW_DESCRIPTOR,
        struct.pack("<Q", size),
    ]
    digest = xxhash.xxh64()
    blocks: list[bytes | memoryview] = []
    pending: list[bytes | memoryview] = []
    pending_size = 0

    def end_pending() -> None:
        nonlocal pending_size
        if pending:
            blocks.append(pending[0] if len(pending) == 1 else b"".join(pending))
            pending.clear()
            pending_size = 0

    for part in parts:
        digest.update(part)
        n = len(part)
        if n <= _SMALL_PART and pending_size + n <= _ZSTD_BLOCK_MAX:
            pending.append(part)
            pending_size += n
            continue
        end_pending()
        if n <= _SMALL_PART:
            pending.append(part)
            pending_size = n
            continue
        view = memoryview(part).cast("B")
        for lo in range(0, n, _ZSTD_BLOCK_MAX):
            blocks.append(view[lo : lo + _ZSTD_BLOCK_MAX])
    end_pending()
    if not blocks:
        blocks.append(b"")
    last = len(blocks) - 1
    for i, block in enumerate(blocks):
        # block header: size << 3 | type (0: raw) << 1 | last block
        out.append(((len(block) << 3) | (i == last)).to_bytes(3, "little"))
        if len(block):
            out.append(block)
    out.append(struct.pack("<I", digest.intdigest() & 0xFFFFFFFF))
    return out


#: encoded Schema and Channel records by content: every run registers the same
#: ones, in the same order
_SCHEMA_RECORDS: dict[tuple[object, ...], bytes] = {}
_CHANNEL_RECORDS: dict[tuple[object, ...], bytes] = {}


def _remember(
    cache: dict[tuple[object, ...], bytes], key: tuple[object, ...], value: bytes
) -> bytes:
    if len(cache) >= 512:
        cache.clear()
    cache[key] = value
    return value


def _string(text: str) -> bytes:
    """An MCAP string: uint32 length and UTF-8 bytes."""
    data = text.encode()
    return struct.pack("<I", len(data)) + data


def _bytes(data: bytes) -> bytes:
    """MCAP bytes with a uint32 length prefix."""
    return struct.pack("<I", len(data)) + data


def _record_bytes(opcode: int, body: bytes) -> bytes:
    return struct.pack("<BQ", opcode, len(body)) + body


class Chunk:
    """Records gathered for one chunk: bytes (or views), message indexes, times."""

    def __init__(self) -> None:
        self.parts: list[bytes | memoryview] = []
        self.size = 0
        self.messages = 0
        self.start = 0
        self.end = 0
        self.indices: dict[int, MessageIndex] = {}


class PackedChunk:
    """A chunk compressed, ready to be written (see :meth:`ChunkWriter.pack`)."""

    def __init__(
        self, chunk: Chunk, head: bytes, data: list[bytes | memoryview], size: int
    ):
        self.chunk = chunk
        self.head = head
        self.data = data  # the compressed bytes, in pieces
        self.packed_size = size


class ChunkWriter:
    """Write MCAP records to ``stream``; messages go into zstd chunks.

    Not thread-safe, except :meth:`pack`, which touches nothing of the writer's: a
    caller may :meth:`take_chunk` under its lock, pack the chunk on another thread
    (zstd releases the GIL) and :meth:`write_packed` it under the lock again.

    Parameters
    ----------
    stream
        A binary stream opened for writing (not closed by this class).
    """

    def __init__(self, stream: IO[bytes]) -> None:
        self._stream = stream
        self._offset = 0
        # encoded Schema and Channel records, by id (written again in the summary)
        self._schemas: dict[int, bytes] = {}
        self._channels: dict[int, bytes] = {}
        self._chunk = Chunk()  # the chunk in progress
        self._chunk_indices: list[ChunkIndex] = []
        self._attachment_indices: list[AttachmentIndex] = []
        self._metadata_indices: list[MetadataIndex] = []
        self._message_counts: dict[int, int] = defaultdict(int)
        self._message_start = 0
        self._message_end = 0
        self._messages = 0

    # -- records -------------------------------------------------------------------
    def _write(self, data: bytes | memoryview) -> None:
        self._stream.write(data)
        self._offset += len(data)

    def _write_all(self, pieces: list[bytes | memoryview]) -> None:
        """Write ``pieces`` in order: with one ``writev`` call to a file (after
        flushing the stream's buffer), one ``write`` each to anything else."""
        size = sum(len(p) for p in pieces)
        try:
            fd = self._stream.fileno()
        except (AttributeError, OSError, ValueError):
            fd = -1
        if fd < 0 or size < _WRITEV_ABOVE or not hasattr(os, "writev"):
            for piece in pieces:
                self._stream.write(piece)
        else:
            self._stream.flush()
            todo = [memoryview(p).cast("B") for p in pieces if len(p)]
            while todo:
                n = os.writev(fd, todo[:_IOV_MAX])
                while todo and n >= len(todo[0]):  # whole pieces written
                    n -= len(todo[0])
                    todo.pop(0)
                if n:  # a piece written in part
                    todo[0] = todo[0][n:]
        self._offset += size

    def _record(self, record: object) -> int:
        """Write one record outside chunks; returns its length."""
        b = RecordBuilder()
        record.write(b)  # type: ignore[attr-defined]
        data = b.end()
        self._write(data)
        return len(data)

    def start(self, profile: str, library: str) -> None:
        """Write the magic and the header."""
        self._write(MAGIC)
        self._record(Header(profile=profile, library=library))

    def register_schema(self, name: str, encoding: str, data: bytes) -> int:
        sid = len(self._schemas) + 1
        key = (sid, name, encoding, data)
        record = _SCHEMA_RECORDS.get(key)
        if record is None:
            # Schema record: id, name, encoding, data (encoded here: the mcap
            # package's builder takes ~0.1 ms a record, and a run registers dozens)
            body = b"".join(
                [struct.pack("<H", sid), _string(name), _string(encoding), _bytes(data)]
            )
            record = _remember(_SCHEMA_RECORDS, key, _record_bytes(Opcode.SCHEMA, body))
        self._schemas[sid] = record
        self._chunk_raw(self._schemas[sid])
        return sid

    def register_channel(
        self,
        topic: str,
        message_encoding: str,
        schema_id: int,
        metadata: dict[str, str],
    ) -> int:
        cid = len(self._channels) + 1
        key = (cid, schema_id, topic, message_encoding, tuple(metadata.items()))
        record = _CHANNEL_RECORDS.get(key)
        if record is None:
            # Channel record: id, schema id, topic, message encoding, metadata map
            entries = b"".join(_string(k) + _string(v) for k, v in metadata.items())
            body = b"".join(
                [
                    struct.pack("<HH", cid, schema_id),
                    _string(topic),
                    _string(message_encoding),
                    _bytes(entries),
                ]
            )
            record = _remember(
                _CHANNEL_RECORDS, key, _record_bytes(Opcode.CHANNEL, body)
            )
        self._channels[cid] = record
        self._chunk_raw(self._channels[cid])
        return cid

    def _chunk_raw(self, data: bytes) -> None:
        self._chunk.parts.append(data)
        self._chunk.size += len(data)

    def add_message(
        self,
        channel_id: int,
        log_time: int,
        data: bytes | memoryview | Sequence[bytes | memoryview],
    ) -> None:
        """Add a message to the chunk in progress. ``data`` may be a list of
        buffers, the message being their concatenation (not copied: they must not
        change before the chunk ends)."""
        parts = [data] if isinstance(data, (bytes, memoryview)) else list(data)
        size = sum(len(p) for p in parts)
        c = self._chunk
        if c.messages == 0:
            c.start = c.end = log_time
        c.start = min(c.start, log_time)
        c.end = max(c.end, log_time)
        if self._messages == 0:
            self._message_start = log_time
        self._message_start = min(self._message_start, log_time)
        self._message_end = max(self._message_end, log_time)
        index = c.indices.get(channel_id)
        if index is None:
            index = c.indices[channel_id] = MessageIndex(channel_id, [])
        index.records.append((log_time, c.size))
        # Message record: opcode, length, channel id, sequence, log and publish time
        head = _MESSAGE.pack(
            Opcode.MESSAGE, 22 + size, channel_id, 0, log_time, log_time
        )
        c.parts += [head, *parts]
        c.size += len(head) + size
        c.messages += 1
        self._messages += 1
        self._message_counts[channel_id] += 1

    def add_attachment(
        self, log_time: int, name: str, media_type: str, data: bytes
    ) -> None:
        offset = self._offset
        length = self._record(
            Attachment(
                create_time=log_time,
                log_time=log_time,
                name=name,
                media_type=media_type,
                data=data,
            )
        )
        self._attachment_indices.append(
            AttachmentIndex(
                offset=offset,
                length=length,
                create_time=log_time,
                log_time=log_time,
                data_size=len(data),
                name=name,
                media_type=media_type,
            )
        )

    def add_metadata(self, name: str, data: dict[str, str]) -> None:
        offset = self._offset
        length = self._record(Metadata(name=name, metadata=data))
        self._metadata_indices.append(
            MetadataIndex(offset=offset, length=length, name=name)
        )

    # -- chunks ----------------------------------------------------------------------
    def flush(self, *, fast: bool = False) -> None:
        """End the chunk in progress (if it has messages) and flush the stream.

        ``fast`` compresses a large chunk at the fastest useful level (for a chunk
        someone waits for); otherwise the level depends on the chunk's size.
        """
        chunk = self.take_chunk()
        if chunk is not None:
            self.write_packed(self.pack(chunk, fast=fast))
        self._stream.flush()

    @property
    def pending_bytes(self) -> int:
        """Bytes of the chunk in progress (records not yet written)."""
        return self._chunk.size

    def take_chunk(self) -> Chunk | None:
        """The chunk in progress (None if it has no message); a new one begins."""
        if not self._chunk.messages:
            return None
        chunk, self._chunk = self._chunk, Chunk()
        return chunk

    @staticmethod
    def pack(chunk: Chunk, *, fast: bool = False) -> PackedChunk:
        """Compress ``chunk`` (any thread; the writer is not touched)."""
        size = chunk.size
        level = next((lv for top, lv in _LEVELS if size <= top), _LEVEL_LARGE)
        if fast:
            level = _LEVEL_FAST if size > _LEVELS[0][0] else _LEVEL_FAST_SMALL
        # one buffer compressed in one call: zstd's streaming mode costs more than
        # the copy. A large or ``fast`` chunk is checked by zstd's own (faster)
        # content checksum instead of the chunk CRC, which MCAP allows to be 0
        # ("not computed").
        use_crc = size <= _FAST_ABOVE and not fast
        parts = chunk.parts
        packed: list[bytes | memoryview]
        if size >= _RAW_ABOVE and _incompressible(parts, size):
            # stored as it is; the chunk CRC is 0 ("not computed"), as for the
            # other large chunks
            packed = raw_zstd_frame(parts, size)
            crc = 0
        else:
            data = parts[0] if len(parts) == 1 else b"".join(parts)
            crc = zlib.crc32(data) if use_crc else 0
            packed = [_compressor(level, not use_crc).compress(data)]
        packed_size = sum(len(p) for p in packed)
        # Chunk record: start/end time, size, crc, compression, records
        body = 8 + 8 + 8 + 4 + 4 + 4 + 8 + packed_size
        head = _CHUNK.pack(
            Opcode.CHUNK,
            body,
            chunk.start,
            chunk.end,
            size,
            crc,
            4,
            b"zstd",
            packed_size,
        )
        return PackedChunk(chunk, head, packed, packed_size)

    def write_packed(self, packed: PackedChunk) -> None:
        """Write a packed chunk and its message indexes (does not flush)."""
        chunk = packed.chunk
        start = self._offset
        length = len(packed.head) + packed.packed_size
        index_start = start + length
        offsets: dict[int, int] = {}
        pieces: list[bytes] = []
        n = 0
        for cid, index in chunk.indices.items():
            # MessageIndex record: channel id, (log time, offset) pairs
            flat = [v for pair in index.records for v in pair]
            body = struct.pack(f"<HI{len(flat)}Q", cid, 8 * len(flat), *flat)
            offsets[cid] = index_start + n
            pieces.append(_record_bytes(Opcode.MESSAGE_INDEX, body))
            n += len(pieces[-1])
        index_data = b"".join(pieces)
        self._write_all([packed.head, *packed.data, index_data])
        self._chunk_indices.append(
            ChunkIndex(
                message_start_time=chunk.start,
                message_end_time=chunk.end,
                chunk_start_offset=start,
                chunk_length=length,
                message_index_offsets=offsets,
                message_index_length=len(index_data),
                compression="zstd",
                compressed_size=packed.packed_size,
                uncompressed_size=chunk.size,
            )
        )

    # -- end ---------------------------------------------------------------------------
    def finish(self) -> None:
        """End the data section and write the summary, footer and closing magic."""
        chunk = self.take_chunk()
        if chunk is not None:
            self.write_packed(self.pack(chunk))
        self._record(DataEnd(0))
        summary_start = self._offset
        b = RecordBuilder()
        offsets: list[SummaryOffset] = []

        def group(opcode: Opcode, records: list[object]) -> None:
            if not records:
                return
            start = b.count
            for r in records:
                if isinstance(r, bytes):
                    b.write(r)
                else:
                    r.write(b)  # type: ignore[attr-defined]
            offsets.append(
                SummaryOffset(opcode, summary_start + start, b.count - start)
            )

        group(Opcode.SCHEMA, list(self._schemas.values()))
        group(Opcode.CHANNEL, list(self._channels.values()))
        stats = Statistics(
            message_count=self._messages,
            schema_count=len(self._schemas),
            channel_count=len(self._channels),
            attachment_count=len(self._attachment_indices),
            metadata_count=len(self._metadata_indices),
            chunk_count=len(self._chunk_indices),
            message_start_time=self._message_start,
            message_end_time=self._message_end,
            channel_message_counts=dict(self._message_counts),
        )
        group(Opcode.STATISTICS, [stats])
        group(Opcode.CHUNK_INDEX, list(self._chunk_indices))
        group(Opcode.ATTACHMENT_INDEX, list(self._attachment_indices))
        group(Opcode.METADATA_INDEX, list(self._metadata_indices))
        summary_offset_start = summary_start + b.count
        for o in offsets:
            o.write(b)
        summary = b.end()
        crc = zlib.crc32(summary)
        crc = zlib.crc32(
            struct.pack(
                "<BQQQ", Opcode.FOOTER, 20, summary_start, summary_offset_start
            ),
            crc,
        )
        self._write(summary)
        self._record(
            Footer(
                summary_start=summary_start,
                summary_offset_start=summary_offset_start,
                summary_crc=crc,
            )
        )
        self._write(MAGIC)
        self._stream.flush()
