"""The MCAP format writer behind ``--trace RUN.mcap`` (see :mod:`pirate_bt.interop.mcap_trace`).

:class:`McapTraceWriter` runs in the trace's **writer process**
(:mod:`pirate_bt.trace.sink`; :func:`pirate_bt.interop.mcap_trace.register`
registers it there), so the run's tick only captures what moved and hands it
over, as for ``.jsonl``. The writer process encodes each tick record, maps it
to topic messages (:class:`~pirate_bt.interop.foxglove_topics.TopicMapper`),
serialises them and writes them twice:

- to the file itself, *unchunked*: each record's messages go to the kernel
  with one ``os.write``, so whatever happens to either process, the file holds
  every record written so far (no chunk waits in memory);
- to a chunked, LZ4-compressed, indexed twin beside it (``.NAME.PID.*.part``;
  :class:`~pirate_bt.interop.mcap_chunks.ChunkedCopy`, the same records in
  chunks). When the run's end record comes, the twin is finished and renamed
  over the file (the file used to be rewritten at the end, read back whole). If
  that fails, the unchunked file is completed with its footer and kept (logged).

When the input ends without an end record (the run was killed), the twin is
deleted and the unchunked file is left as it is: no summary, no footer
(:meth:`McapTraceWriter.cut_off`). When the writer process itself is killed, its
twin stays; the next writer of the same file deletes it.

This module imports only the standard library and modules of ``pirate_bt`` that
do (the writer process imports it by name); ``mcap`` (the ``foxglove`` extra) is
imported when a file is opened.
"""

from __future__ import annotations

import contextlib
import json
import logging
import os
import re
import struct
import tempfile
from pathlib import Path
from typing import IO, Any, ClassVar

from pirate_bt.atomic import cut_name, write_atomically
from pirate_bt.errors import ConfigurationError, InputError, file_argument, output_argument
from pirate_bt.interop.foxglove_topics import (
    TOPICS,
    TopicMapper,
    TopicMessage,
    encode_message,
    missing_extra,
    schema_of,
)
from pirate_bt.interop.mcap_chunks import ChunkedCopy
from pirate_bt.trace.sink_formats import TraceFormatWriter, to_null

__all__ = ["CHUNK_BYTES", "McapTraceWriter", "compact_mcap", "load_mcap"]

logger = logging.getLogger(__name__)

_MESSAGE = struct.Struct("<BQHIQQ")
"""An MCAP Message record's opcode, length, channel, sequence, log and publish time."""
_MAGIC = b"\x89MCAP0\r\n"
CHUNK_BYTES = 1 << 20
"""Uncompressed size of one chunk in a compacted or exported file."""


def load_mcap() -> Any:
    try:
        import mcap.data_stream
        import mcap.exceptions
        import mcap.records
        import mcap.stream_reader
        import mcap.writer
    except ImportError:
        raise ConfigurationError(missing_extra("MCAP", "mcap")) from None
    return mcap


def _library() -> str:
    from pirate_bt._version import __version__

    return f"pirate_bt {__version__}"


class _Channels:
    """A schema and a channel per topic on an MCAP writer."""

    def __init__(self, writer: Any) -> None:
        self.ids: dict[str, int] = {}
        for topic in TOPICS:
            name, schema = schema_of(topic)
            schema_id = writer.register_schema(
                name=name, encoding="jsonschema", data=json.dumps(schema).encode("utf-8")
            )
            self.ids[topic] = writer.register_channel(
                topic=topic, message_encoding="json", schema_id=schema_id
            )
        self.sequence = 0

    def add(self, writer: Any, message: TopicMessage) -> None:
        self.sequence += 1
        writer.add_message(
            channel_id=self.ids[message.topic],
            log_time=message.log_time_ns,
            publish_time=message.log_time_ns,
            data=encode_message(message.message),
            sequence=self.sequence,
        )


def _chunked_writer(stream: IO[bytes], profile: str = "") -> Any:
    mcap = load_mcap()
    writer: Any = mcap.writer.Writer(
        stream, chunk_size=CHUNK_BYTES, compression=mcap.writer.CompressionType.LZ4
    )
    writer.start(profile=profile, library=_library())
    return writer


# --- writing a run directly --------------------------------------------------------


class _Buffer:
    """A write-only stream that keeps what is written until :meth:`take`."""

    def __init__(self) -> None:
        self.parts: list[bytes] = []
        self.position = 0

    def write(self, data: bytes) -> int:
        self.parts.append(bytes(data))
        self.position += len(data)
        return len(data)

    def tell(self) -> int:
        return self.position

    def flush(self) -> None:
        pass

    def take(self) -> bytes:
        data = b"".join(self.parts)
        self.parts.clear()
        return data


def _schema_record(topic: str) -> tuple[str, str, bytes]:
    """A topic's schema as an MCAP Schema record holds it: name, encoding, data."""
    name, schema = schema_of(topic)
    return name, "jsonschema", json.dumps(schema).encode("utf-8")


def _twin_prefix(path: Path) -> str:
    """``.NAME.PID.``: the start of the names of ``path``'s chunked twins.

    NAME is the file's name cut to 64 bytes, as :func:`pirate_bt.atomic.write_atomically`
    cuts it: a name may have 255 bytes, and the whole name with a dot before and
    ``.XXXXXXXX.part`` after was refused (``--trace`` of a 245-byte name failed the
    run with ``File name too long``, where ``.jsonl`` wrote it). PID is the writing
    process's, so that a twin left by a writer that was killed can be told from one
    being written (:func:`_drop_orphan_twins`).
    """
    return f".{cut_name(path.name)}.{os.getpid()}."


def _temporary_beside(path: Path) -> tuple[int, str]:
    """A new file beside ``path`` (``.NAME.PID.*.part``) with the mode ``open`` would give it."""
    fd, temp = tempfile.mkstemp(prefix=_twin_prefix(path), suffix=".part", dir=path.parent)
    mask = os.umask(0)
    os.umask(mask)
    os.chmod(temp, 0o666 & ~mask)  # mkstemp makes it private
    return fd, temp


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # another user's process: alive
        return True
    return True


def _drop_orphan_twins(path: Path) -> None:
    """Delete the twins of ``path`` whose writer is gone (killed before it could).

    A writer process killed with SIGKILL left its ``.NAME.PID.*.part`` behind, one
    more hidden file (as large as the run's chunks) for every kill; the next writer
    of the same file deletes them. A twin of a writer still running is left alone.
    """
    pattern = re.compile(re.escape(f".{cut_name(path.name)}.") + r"(\d+)\.[A-Za-z0-9_]{8}\.part")
    try:
        entries = list(os.scandir(path.parent))
    except OSError:
        return
    for entry in entries:
        found = pattern.fullmatch(entry.name)
        if found is None or _alive(int(found[1])):
            continue
        with contextlib.suppress(OSError):
            os.unlink(entry.path)
            logger.info("%s: deleted %s, left by a writer that was killed", path, entry.name)


class McapTraceWriter(TraceFormatWriter):
    """Writes a run's trace as MCAP (``.mcap``), record by record.

    See the module docstring for what is on disk while the run goes on and after
    it ends. A recorder runs it in its writer process; opened directly
    (:func:`pirate_bt.trace.open_writer`) it runs in the caller's process.

    Args:
        path: The MCAP file (created or truncated).
        sync: Also fsync after every record (power loss).
        fd: An open file descriptor to write to instead.
        compact: Leave the file chunked, compressed and indexed when it closes
            (written as it goes, beside it); ``False`` leaves it unchunked.

    Raises:
        ConfigurationError: the ``mcap`` package is missing.
        OSError: the file cannot be created.
    """

    suffixes: ClassVar[tuple[str, ...]] = (".mcap",)

    @classmethod
    def preflight(cls, path: Path) -> None:
        """Raise :class:`~pirate_bt.errors.ConfigurationError` when ``mcap`` is missing.

        Looked for, not imported: the run's process never needs it.
        """
        import importlib.util

        if importlib.util.find_spec("mcap") is None:
            raise ConfigurationError(missing_extra("MCAP", "mcap"))

    def __init__(
        self, path: str | Path, sync: bool = False, fd: int | None = None, compact: bool = True
    ) -> None:
        mcap = load_mcap()
        self._buffer = _Buffer()
        self._twin: Any = None
        self._twin_path: str | None = None
        self._ended = False
        self._cut = False
        super().__init__(path, sync=sync, fd=fd)
        # The start of an unchunked MCAP file: magic, header, a schema and a channel per
        # topic, each record written as it comes (no chunk to lose in a crash).
        records = mcap.records
        builder = mcap.data_stream.RecordBuilder()
        records.Header(profile="", library=_library()).write(builder)
        self._ids: dict[str, int] = {}
        for number, topic in enumerate(TOPICS, start=1):
            name, encoding, data = _schema_record(topic)
            records.Schema(id=number, name=name, encoding=encoding, data=data).write(builder)
            records.Channel(
                id=number, topic=topic, message_encoding="json", schema_id=number, metadata={}
            ).write(builder)
            self._ids[topic] = number
        self._buffer.write(_MAGIC + builder.end())
        self._mapper = TopicMapper()
        self._sequence = 0
        self._finished = False
        self._emit()
        if compact:
            _drop_orphan_twins(self.path)
            twin_fd, self._twin_path = _temporary_beside(self.path)
            try:
                self._twin_file = open(twin_fd, "wb")  # noqa: SIM115 - closed in close()
                self._twin = ChunkedCopy(
                    mcap,
                    self._twin_file,
                    _library(),
                    [(n, *_schema_record(topic)) for n, topic in enumerate(TOPICS, start=1)],
                    [(n, topic, "json", n) for n, topic in enumerate(TOPICS, start=1)],
                    CHUNK_BYTES,
                )
            except BaseException:
                self._drop_twin()
                raise

    @property
    def compact(self) -> bool:
        """Whether the file is left chunked, compressed and indexed when it closes."""
        return self._twin is not None

    def _open(self, fd: int | None) -> IO[bytes]:
        if fd is None:
            fd = self._claimed()  # the file claimed, not the path again
        if fd is not None:
            return open(fd, "wb", buffering=0)
        return open(self.path, "wb", buffering=0)

    def _emit(self) -> None:
        data = self._buffer.take()
        if not data:
            return
        out = self._file.fileno()
        written = os.write(out, data)
        while written < len(data):
            written += os.write(out, data[written:])
        if self.sync:
            os.fsync(out)

    def write_line(self, line: str) -> None:
        """Map one record (its JSON text) to messages and write them with one ``os.write``."""
        self.write_record(json.loads(line))

    def write(self, record: Any) -> None:
        """Write one record given as data."""
        self.write_record(record)

    def write_record(self, record: Any) -> None:
        """Write the messages of one record; they are in the kernel's hands on return."""
        # Message records are packed here, one struct each: the mcap Writer builds them
        # field by field in Python, several times slower.
        parts = self._buffer.parts
        ids, pack = self._ids, _MESSAGE.pack
        twin = self._twin
        for message in self._mapper.messages(record):
            data = encode_message(message.message)
            self._sequence += 1
            when = message.log_time_ns
            channel = ids[message.topic]
            head = pack(5, 22 + len(data), channel, self._sequence, when, when)
            parts.append(head)
            parts.append(data)
            if twin is not None:
                twin.add(head, data, channel, when)
        if record.get("type") == "end":
            self._ended = True
        self._emit()

    def cut_off(self) -> None:
        """The run was cut off: :meth:`close` leaves the file unchunked, with no footer."""
        self._cut = True

    def _forked(self) -> None:
        # In a forked copy: the chunked twin is the run's, not to be renamed over the
        # trace nor removed by this copy's close (which writes nothing then).
        file = getattr(self, "_twin_file", None)
        if self._twin_path is not None and file is not None and not file.closed:
            to_null(file.fileno())  # its buffer is flushed into nothing
            file.close()
        self._twin = self._twin_path = None
        self._cut = True
        super()._forked()

    def close(self) -> None:
        """Finish the file: the chunked twin renamed over it, or its footer (idempotent)."""
        if self._file.closed:
            return
        try:
            if self._cut:
                return  # as a killed run leaves it: every record, no summary, no footer
            if self._twin is not None:
                try:
                    self._finish_twin()
                    return
                except Exception as exc:  # the unchunked file is complete and readable
                    logger.warning("%s: kept unchunked, could not compact it: %s", self.path, exc)
            self._finish_unchunked()
        finally:
            self._drop_twin()
            super().close()

    def _finish_unchunked(self) -> None:
        if self._finished:
            return
        self._finished = True
        # The end of an MCAP file without a summary section (the messages did not go
        # through the Writer, whose summary would not count them).
        mcap = load_mcap()
        builder = mcap.data_stream.RecordBuilder()
        mcap.records.DataEnd(0).write(builder)
        mcap.records.Footer(0, 0, 0).write(builder)
        self._buffer.write(builder.end())
        self._buffer.write(_MAGIC)
        self._emit()

    def _finish_twin(self) -> None:
        assert self._twin_path is not None
        self._twin.finish()
        self._twin_file.flush()
        os.fsync(self._twin_file.fileno())
        self._twin_file.close()
        os.replace(self._twin_path, self.path)
        self._twin = self._twin_path = None

    def _drop_twin(self) -> None:
        if self._twin_path is None:
            return
        file = getattr(self, "_twin_file", None)
        if file is not None:
            with contextlib.suppress(OSError):
                file.close()
        with contextlib.suppress(OSError):
            os.unlink(self._twin_path)
        self._twin = self._twin_path = None


def compact_mcap(path: Path, out_path: Path | None = None) -> Path:
    """Rewrite an MCAP file of pirate_bt's chunked, LZ4-compressed and indexed.

    Also recovers a file cut off by a crash (up to its last complete record).

    Args:
        path: The file to read.
        out_path: Where to write (default: replace ``path``, atomically).

    Returns:
        The file written.

    Raises:
        InputError: ``path`` cannot be read or is not MCAP (nothing is written; until
            2026-11-29 it was replaced by an empty MCAP file), or is damaged before its
            end and would be replaced (what follows the damage would be lost; another
            ``out_path`` keeps what comes before it); the output cannot be written.
    """
    from pirate_bt.yamlfile import special_file

    # checked as read_mcap_records checks its path: a number was opened as a file
    # descriptor, None was a TypeError traceback, a named pipe was waited on for ever
    path = file_argument(path, "path")
    kind = special_file(path)
    if kind is not None:
        raise InputError(f"{path}: cannot read: it is {kind}, not a file")
    if out_path is not None:
        out_path = output_argument(out_path, "out_path")
    load_mcap()
    from mcap.records import Attachment, Channel, Header, Message, Metadata, Schema
    from mcap.stream_reader import StreamReader

    out = Path(out_path or path)
    in_place = out_path is None or _same_file(out, Path(path))

    def fill(stream: IO[bytes]) -> None:
        writer: Any = None
        schemas: dict[int, int] = {}
        channels: dict[int, int] = {}
        read = 0
        with open(path, "rb") as source:
            try:
                # CRCs checked: damage inside a chunk was copied on as it was read
                for record in StreamReader(source, validate_crcs=True).records:
                    read += 1
                    if writer is None:
                        # the file's profile kept ("ros2" for a bag's file): until
                        # 2026-11-30 it was dropped, with its metadata and attachments
                        profile = record.profile if isinstance(record, Header) else ""
                        writer = _chunked_writer(stream, profile)
                    if isinstance(record, Metadata):
                        writer.add_metadata(record.name, dict(record.metadata))
                    elif isinstance(record, Attachment):
                        writer.add_attachment(
                            record.create_time,
                            record.log_time,
                            record.name,
                            record.media_type,
                            record.data,
                        )
                    elif isinstance(record, Schema) and record.id not in schemas:
                        schemas[record.id] = writer.register_schema(
                            record.name, record.encoding, record.data
                        )
                    elif isinstance(record, Channel) and record.id not in channels:
                        channels[record.id] = writer.register_channel(
                            record.topic,
                            record.message_encoding,
                            schemas.get(record.schema_id, 0),
                            dict(record.metadata),
                        )
                    elif isinstance(record, Message) and record.channel_id in channels:
                        writer.add_message(
                            channels[record.channel_id],
                            record.log_time,
                            record.data,
                            record.publish_time,
                            record.sequence,
                        )
            except Exception as exc:  # the reader's, a decompressor's (zstd, lz4)
                cut = _cut_off(exc, source)
                if not read:
                    reason = "cut off before its first record" if cut else str(exc)
                    raise InputError(
                        f"{path}: not a readable MCAP file ({reason}); nothing written"
                    ) from None
                if not cut and in_place:
                    raise InputError(
                        f"{path}: damaged after {read} record{'s' if read != 1 else ''}:"
                        f" {exc}; not compacted in"
                        " place, which would drop what follows (give another output to keep"
                        " what comes before)"
                    ) from None
                if not cut:
                    logger.warning("%s: damaged after %d records (%s): kept those", path, read, exc)
                # a cut-off end: keep what was complete
        (writer or _chunked_writer(stream)).finish()

    try:
        return write_atomically(out, fill, durable=True)
    except OSError as exc:
        raise InputError(f"cannot compact {path} into {out}: {exc.strerror or exc}") from None


def _cut_off(exc: Exception, stream: IO[bytes]) -> bool:
    """Whether the stream reader's ``exc`` means the file ends there (cut off), not
    that it is damaged: the reader ran out of bytes (a record cut short reads as a
    ``struct.error`` at the end of the file)."""
    mcap = load_mcap()
    if isinstance(exc, mcap.exceptions.EndOfFile | EOFError):
        return True
    try:
        return stream.tell() >= os.fstat(stream.fileno()).st_size
    except (OSError, ValueError):
        return False


def _same_file(one: Path, other: Path) -> bool:
    try:
        return os.path.samefile(one, other)
    except OSError:
        return False
