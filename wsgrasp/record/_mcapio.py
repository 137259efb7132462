"""A small chunked MCAP writer that picks the zstd level per chunk.

``mcap.writer.Writer`` compresses every chunk at zstd's default level, which costs
~3 ms per MB on the float arrays a run is mostly made of, and gains nothing on them
(noisy float64 does not compress). This writer ends a chunk only when asked
(``flush``), compresses small structured chunks at level 3 and larger ones at
fast levels (see ``_LEVELS``), and otherwise writes the same records, indexes and
summary as ``mcap.writer.Writer`` (it builds them with ``mcap.records``).
"""

from __future__ import annotations

import struct
import zlib
from collections import defaultdict
from typing import IO

import zstandard
from mcap.data_stream import RecordBuilder
from mcap.opcode import Opcode
from mcap.records import (
    Attachment,
    AttachmentIndex,
    Channel,
    ChunkIndex,
    DataEnd,
    Footer,
    Header,
    MessageIndex,
    Metadata,
    MetadataIndex,
    Schema,
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
#: chunks larger than this are checked by zstd's checksum, not the chunk CRC
_FAST_ABOVE = 512 * 1024


class ChunkWriter:
    """Write MCAP records to ``stream``; messages go into zstd chunks.

    Parameters
    ----------
    stream
        A binary stream opened for writing (not closed by this class).
    """

    def __init__(self, stream: IO[bytes]) -> None:
        self._stream = stream
        self._offset = 0
        self._schemas: dict[int, Schema] = {}
        self._channels: dict[int, Channel] = {}
        # the chunk in progress: record bytes, joined once when the chunk ends
        self._chunk: list[bytes | memoryview] = []
        self._chunk_size = 0
        self._chunk_messages = 0
        self._chunk_start = 0
        self._chunk_end = 0
        self._indices: dict[int, MessageIndex] = {}
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
        schema = Schema(id=sid, name=name, encoding=encoding, data=data)
        self._schemas[sid] = schema
        self._chunk_record(schema)
        return sid

    def register_channel(
        self,
        topic: str,
        message_encoding: str,
        schema_id: int,
        metadata: dict[str, str],
    ) -> int:
        cid = len(self._channels) + 1
        channel = Channel(
            id=cid,
            topic=topic,
            message_encoding=message_encoding,
            schema_id=schema_id,
            metadata=metadata,
        )
        self._channels[cid] = channel
        self._chunk_record(channel)
        return cid

    def _chunk_record(self, record: object) -> None:
        b = RecordBuilder()
        record.write(b)  # type: ignore[attr-defined]
        data = b.end()
        self._chunk.append(data)
        self._chunk_size += len(data)

    def add_message(self, channel_id: int, log_time: int, data: bytes) -> None:
        """Add a message to the chunk in progress."""
        if self._chunk_messages == 0:
            self._chunk_start = self._chunk_end = log_time
        self._chunk_start = min(self._chunk_start, log_time)
        self._chunk_end = max(self._chunk_end, log_time)
        if self._messages == 0:
            self._message_start = log_time
        self._message_start = min(self._message_start, log_time)
        self._message_end = max(self._message_end, log_time)
        index = self._indices.get(channel_id)
        if index is None:
            index = self._indices[channel_id] = MessageIndex(channel_id, [])
        index.records.append((log_time, self._chunk_size))
        # Message record: opcode, length, channel id, sequence, log and publish time
        head = _MESSAGE.pack(
            Opcode.MESSAGE, 22 + len(data), channel_id, 0, log_time, log_time
        )
        self._chunk += [head, data]
        self._chunk_size += len(head) + len(data)
        self._chunk_messages += 1
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
    def flush(self) -> None:
        """End the chunk in progress (if it has messages) and flush the stream."""
        if self._chunk_messages:
            self._end_chunk()
        self._stream.flush()

    def _end_chunk(self) -> None:
        parts, size = self._chunk, self._chunk_size
        self._chunk, self._chunk_size = [], 0
        level = next((lv for top, lv in _LEVELS if size <= top), _LEVEL_LARGE)
        # compress and checksum part by part: no copy of the whole chunk. A large
        # chunk is checked by zstd's own (faster) content checksum instead of the
        # chunk CRC, which MCAP allows to be 0 ("not computed").
        small = size <= _FAST_ABOVE
        z = zstandard.ZstdCompressor(level=level, write_checksum=not small)
        zobj = z.compressobj(size=size)
        out: list[bytes] = []
        crc = 0
        for part in parts:
            if small:
                crc = zlib.crc32(part, crc)
            out.append(zobj.compress(part))
        out.append(zobj.flush())
        packed_size = sum(len(o) for o in out)
        start = self._offset
        # Chunk record: start/end time, size, crc, compression, records
        body = 8 + 8 + 8 + 4 + 4 + 4 + 8 + packed_size
        head = _CHUNK.pack(
            Opcode.CHUNK,
            body,
            self._chunk_start,
            self._chunk_end,
            size,
            crc,
            4,
            b"zstd",
            packed_size,
        )
        self._write(head)
        for o in out:
            self._write(o)
        length = len(head) + packed_size
        index_start = self._offset
        offsets: dict[int, int] = {}
        b = RecordBuilder()
        for cid, index in self._indices.items():
            offsets[cid] = index_start + b.count
            index.write(b)
        index_data = b.end()
        self._write(index_data)
        self._chunk_indices.append(
            ChunkIndex(
                message_start_time=self._chunk_start,
                message_end_time=self._chunk_end,
                chunk_start_offset=start,
                chunk_length=length,
                message_index_offsets=offsets,
                message_index_length=len(index_data),
                compression="zstd",
                compressed_size=packed_size,
                uncompressed_size=size,
            )
        )
        self._indices = {}
        self._chunk_messages = 0

    # -- end ---------------------------------------------------------------------------
    def finish(self) -> None:
        """End the data section and write the summary, footer and closing magic."""
        if self._chunk_messages:
            self._end_chunk()
        self._record(DataEnd(0))
        summary_start = self._offset
        b = RecordBuilder()
        offsets: list[SummaryOffset] = []

        def group(opcode: Opcode, records: list[object]) -> None:
            if not records:
                return
            start = b.count
            for r in records:
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
