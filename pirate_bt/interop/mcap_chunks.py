"""A chunked, LZ4-compressed, indexed MCAP file written from message records packed already.

:class:`~pirate_bt.interop.mcap_writer.McapTraceWriter` packs each message as an
MCAP Message record for its unchunked file; :class:`ChunkedCopy` writes the
same records into chunks of the finished file beside it, as they come. It does
per message only what costs nothing (keep the bytes, note the channel, time and
offset for the message index) and leaves the records of the file's structure to
the ``mcap`` library's record classes (chunks, message and chunk indexes,
statistics, the summary and its offsets, the footer), once per chunk or file.
The ``mcap`` library's own ``Writer`` builds each message again, field by field
in Python, which made it the biggest part of the writer process's work.

The file is what ``mcap.writer.Writer(stream, chunk_size=CHUNK_BYTES,
compression=LZ4)`` writes: schemas and channels in the data section and again in
the summary, statistics, chunk indexes, summary offsets, CRCs of the chunks and
of the summary. The tests read it with the library's indexed reader.
"""

from __future__ import annotations

import struct
import zlib
from typing import IO, Any

__all__ = ["ChunkedCopy"]

_FOOTER = struct.Struct("<BQQQ")
_MAGIC = b"\x89MCAP0\r\n"


class ChunkedCopy:
    """An MCAP file written chunk by chunk to ``stream``.

    Args:
        mcap: The ``mcap`` package (imported by the caller).
        stream: Where to write (a file open for binary writing).
        library: The header's library name.
        schemas: ``(id, name, encoding, data)`` of each schema.
        channels: ``(id, topic, message_encoding, schema_id)`` of each channel.
        chunk_bytes: Uncompressed size at which a chunk is closed.
    """

    def __init__(
        self,
        mcap: Any,
        stream: IO[bytes],
        library: str,
        schemas: list[tuple[int, str, str, bytes]],
        channels: list[tuple[int, str, str, int]],
        chunk_bytes: int,
    ) -> None:
        import importlib

        # The mcap package's own dependency for LZ4 (no type hints of its own).
        self._compress = importlib.import_module("lz4.frame").compress
        self._records = mcap.records
        self._builder = mcap.data_stream.RecordBuilder
        self._stream = stream
        self._position = 0
        self._chunk_bytes = chunk_bytes
        records = self._records
        self._schemas = [
            records.Schema(id=i, name=name, encoding=encoding, data=data)
            for i, name, encoding, data in schemas
        ]
        self._channels = [
            records.Channel(
                id=i, topic=topic, message_encoding=encoding, schema_id=schema, metadata={}
            )
            for i, topic, encoding, schema in channels
        ]
        builder = self._builder()
        records.Header(profile="", library=library).write(builder)
        for record in (*self._schemas, *self._channels):
            record.write(builder)
        self._write(_MAGIC + builder.end())
        self._parts: list[bytes] = []
        self._size = 0
        self._index: dict[int, list[tuple[int, int]]] = {}
        self._start = self._end = 0
        self._chunk_indexes: list[Any] = []
        self._counts: dict[int, int] = {}
        self._messages = 0
        self._first = self._last = 0

    def _write(self, data: bytes) -> None:
        self._stream.write(data)
        self._position += len(data)

    def add(self, head: bytes, data: bytes, channel: int, log_time: int) -> None:
        """Add one Message record (``head``, the packed fields, then ``data``)."""
        if not self._parts:
            self._start = self._end = log_time
        elif log_time < self._start:
            self._start = log_time
        elif log_time > self._end:
            self._end = log_time
        index = self._index.get(channel)
        if index is None:
            index = self._index[channel] = []
        index.append((log_time, self._size))
        self._parts.append(head)
        self._parts.append(data)
        self._size += len(head) + len(data)
        self._counts[channel] = self._counts.get(channel, 0) + 1
        if self._size > self._chunk_bytes:
            self._finish_chunk()

    def _finish_chunk(self) -> None:
        if not self._parts:
            return
        records = self._records
        data = b"".join(self._parts)
        compressed = self._compress(data)
        count = sum(len(index) for index in self._index.values())
        if self._messages == 0:
            self._first, self._last = self._start, self._end
        else:
            self._first, self._last = min(self._first, self._start), max(self._last, self._end)
        self._messages += count
        builder = self._builder()
        records.Chunk(
            compression="lz4",
            data=compressed,
            message_start_time=self._start,
            message_end_time=self._end,
            uncompressed_crc=zlib.crc32(data),
            uncompressed_size=len(data),
        ).write(builder)
        chunk = builder.end()
        chunk_start = self._position
        self._write(chunk)
        index_start = self._position
        offsets: dict[int, int] = {}
        parts = []
        at = index_start
        for channel, entries in self._index.items():
            # A MessageIndex record, packed at once (the record class writes each number
            # with a call of its own): channel, byte length, (log time, offset) pairs.
            flat = [number for entry in entries for number in entry]
            size = 8 * len(flat)
            parts.append(struct.pack(f"<BQHI{len(flat)}Q", 7, 6 + size, channel, size, *flat))
            offsets[channel] = at
            at += 15 + size
        indexes = b"".join(parts)
        self._write(indexes)
        self._chunk_indexes.append(
            records.ChunkIndex(
                message_start_time=self._start,
                message_end_time=self._end,
                chunk_start_offset=chunk_start,
                chunk_length=len(chunk),
                message_index_offsets=offsets,
                message_index_length=len(indexes),
                compression="lz4",
                compressed_size=len(compressed),
                uncompressed_size=len(data),
            )
        )
        self._parts = []
        self._size = 0
        self._index = {}

    def finish(self) -> None:
        """Close the last chunk; write the summary, its offsets and the footer."""
        records = self._records
        self._finish_chunk()
        builder = self._builder()
        records.DataEnd(0).write(builder)
        self._write(builder.end())
        summary_start = self._position
        summary = self._builder()
        offsets = []
        statistics = records.Statistics(
            message_count=self._messages,
            schema_count=len(self._schemas),
            channel_count=len(self._channels),
            attachment_count=0,
            metadata_count=0,
            chunk_count=len(self._chunk_indexes),
            message_start_time=self._first,
            message_end_time=self._last,
            channel_message_counts=dict(self._counts),
        )
        opcode = mcap_opcode()
        for group, items in (
            (opcode.SCHEMA, self._schemas),
            (opcode.CHANNEL, self._channels),
            (opcode.STATISTICS, [statistics]),
            (opcode.CHUNK_INDEX, self._chunk_indexes),
        ):
            start = summary.count
            for item in items:
                item.write(summary)
            offsets.append(
                records.SummaryOffset(
                    group_opcode=group,
                    group_start=summary_start + start,
                    group_length=summary.count - start,
                )
            )
        offset_start = summary_start + summary.count
        for offset in offsets:
            offset.write(summary)
        data = summary.end()
        footer = _FOOTER.pack(opcode.FOOTER, 20, summary_start, offset_start)
        crc = zlib.crc32(footer, zlib.crc32(data))
        self._write(data)
        builder = self._builder()
        records.Footer(
            summary_start=summary_start, summary_offset_start=offset_start, summary_crc=crc
        ).write(builder)
        self._write(builder.end() + _MAGIC)


def mcap_opcode() -> Any:
    """The ``mcap`` library's table of record opcodes."""
    from mcap.opcode import Opcode

    return Opcode
