"""Traces as MCAP files, for Foxglove and Lichtblick.

MCAP is the log container Foxglove, Lichtblick and ROS 2 read. A pirate_bt run
becomes one MCAP file with a JSON-Schema channel per topic (the robot state, the
tree's statuses, the supervisor's verdicts, link health, the simulator's truth,
the localisation belief, log lines; see :mod:`pirate_bt.interop.foxglove_topics`),
messages in the ``json`` encoding, log times on the run's clock.

Two ways in:

- :func:`export_mcap` converts a finished trace (``.jsonl``, ``.jsonl.gz``):
  ``pirate-bt trace export RUN.jsonl -o RUN.mcap``. The file is written beside
  the target under a temporary name and renamed into place, so an error leaves
  nothing half-written. It is chunked, LZ4-compressed and indexed.
- :class:`McapTraceWriter` writes a run directly (``--trace RUN.mcap``; it is
  registered for ``.mcap`` in :data:`pirate_bt.trace.WRITERS`, and with the
  trace's writer process, :func:`pirate_bt.trace.sink.register_process_writer`).
  The run's tick only captures what moved and hands it to the writer process, as
  for ``.jsonl``; that process maps the records to topic messages, serialises
  and writes them. While the run goes on the file is *unchunked*: each record's
  messages go to the kernel with one ``os.write``, so a run killed with SIGKILL
  leaves every tick it handed over on disk (the writer process outlives it) and
  no summary (:func:`read_mcap_records` and Foxglove read such a file; the
  ``mcap`` CLI's ``recover`` command turns it into an indexed one). A chunked,
  compressed and indexed copy is written beside it as it goes and renamed over
  it when the run ends (if that fails, the unchunked file is kept and the reason
  logged); see :mod:`pirate_bt.interop.mcap_writer`.

:func:`read_mcap_records` turns a file back into the trace's records, and
:class:`McapTraceReader` offers them to :func:`pirate_bt.trace.read_trace`'s
table of readers, one by one as the file is read, chunk by chunk (a long run's
file is never held whole).

The format registers itself: importing this module calls :func:`register`, and
pirate-bt's ``pirate_bt.trace_formats`` entry point (``mcap =
"pirate_bt.interop.mcap_trace:register"``) makes :mod:`pirate_bt.trace` load it
the first time it meets a suffix it does not know, so the trace package never
imports this one. Neither needs the ``mcap`` package: it is imported when a file
is opened, and its absence is one clear line then.
"""

from __future__ import annotations

import contextlib
import heapq
import itertools
import json
import os
from collections.abc import Generator, Iterator
from pathlib import Path
from typing import IO, Any, ClassVar

from pirate_bt.atomic import write_atomically
from pirate_bt.errors import InputError, file_argument, output_argument
from pirate_bt.interop.foxglove_schemas import RUN, TOPICS
from pirate_bt.interop.foxglove_topics import TopicMapper, records_from_messages
from pirate_bt.interop.mcap_order import _by_sequence as _by_sequence
from pirate_bt.interop.mcap_order import _in_order as _in_order
from pirate_bt.interop.mcap_order import _one_time_in_order as _one_time_in_order
from pirate_bt.interop.mcap_order import _sequenced as _sequenced
from pirate_bt.interop.mcap_order import _Timed
from pirate_bt.interop.mcap_writer import (
    McapTraceWriter,
    _Channels,
    _chunked_writer,
    _cut_off,
    compact_mcap,
    load_mcap,
)
from pirate_bt.trace.reader import TraceFormatReader, no_header, open_reader, register_reader
from pirate_bt.trace.record_values import readable_text
from pirate_bt.trace.records import BAD_RECORD
from pirate_bt.trace.sink import register_process_writer
from pirate_bt.trace.writer import register_writer
from pirate_bt.yamlfile import special_file

MERGED_RUNS = 32
"""The most stretches of non-decreasing log times another tool's file without an index
is merged from, each read by a reader of its own (one open file each): a file written
channel by channel has one a channel."""

__all__ = [
    "McapTraceReader",
    "McapTraceWriter",
    "compact_mcap",
    "export_mcap",
    "read_mcap_messages",
    "read_mcap_records",
    "register",
]


def export_mcap(trace_path: Path, out_path: Path) -> Path:
    """Convert a trace file (any suffix :func:`pirate_bt.trace.read_trace` reads) to MCAP.

    Every record is kept (see :func:`read_mcap_records`). A trace cut off by a
    crash converts up to its last complete tick.

    Args:
        trace_path: The trace.
        out_path: The MCAP file to write (replaced only once it is complete).

    Returns:
        ``out_path``.

    Raises:
        InputError: a path that is no file name (an output that is a folder too), the
            trace cannot be read, is not a trace or has a bad record, or the output
            cannot be written.
        ConfigurationError: the ``mcap`` package is missing.
    """
    trace_path = file_argument(trace_path, "trace_path")
    out = output_argument(out_path, "out_path")
    load_mcap()
    reader = open_reader(trace_path)
    records = iter(reader)

    def fill(stream: IO[bytes]) -> None:
        writer = _chunked_writer(stream)
        channels = _Channels(writer)
        mapper = TopicMapper()
        first = True
        for line, record in records:
            if first and record.get("type") != "header":
                raise InputError(f"{trace_path}:{line}: not a trace: the first record is no header")
            first = False
            try:
                for message in mapper.messages(record):
                    channels.add(writer, message)
            except BAD_RECORD as exc:  # a time out of range was an internal error
                raise InputError(
                    f"{trace_path}:{line}: cannot convert this record: {exc}"
                ) from None
        if first:
            raise no_header(trace_path, reader.truncated)
        writer.finish()

    try:
        return write_atomically(out, fill, durable=True)
    except OSError as exc:
        raise InputError(f"out_path: cannot write {out}: {exc.strerror or exc}") from None


# --- reading -----------------------------------------------------------------------


def read_mcap_messages(path: str | Path) -> tuple[list[tuple[str, dict[str, Any]]], bool]:
    """Every JSON message of an MCAP file as ``(topic, message)``, in file order (in
    log-time order when another library wrote the file: :meth:`_Messages.timed`).

    Reads with the ``mcap`` library's stream reader, so a file without a summary
    (a run that was killed) reads too, up to its last complete record. Messages of
    channels in another encoding (CDR, Protobuf...) are skipped.

    Returns:
        The messages, and whether the file was cut off (no footer).

    Raises:
        InputError: ``path`` is no file name (a number, ``None``, empty; see
            :func:`~pirate_bt.errors.file_argument`) or no file (a folder, a named
            pipe), the file cannot be read or is not MCAP, or a whole message of a
            JSON channel is no JSON object (named by its number among the messages).
        ConfigurationError: the ``mcap`` package is missing.
    """
    messages = _Messages(path)
    return list(messages), messages.cut


class _Messages:
    """The JSON messages of an MCAP file as :func:`read_mcap_messages` reads them, one
    at a time as the file is read, chunk by chunk: a long run's trace is never held
    whole (its reader held every message of a 100,000-tick run before the first
    record). Iterated once; then ``cut`` says whether the file was cut off (no
    footer), ``encodings`` gives every channel's topic with its encoding and
    ``count`` the messages given. With ``readable``, text is mended as
    :func:`~pirate_bt.trace.record_values.readable_text` mends a ``.jsonl`` line's (a
    :class:`~pirate_bt.trace.Trace` is shown).

    The errors are :func:`read_mcap_messages`'s, raised where the reading meets
    them: after the messages before the damage were given.
    """

    def __init__(self, path: str | Path, readable: bool = False) -> None:
        # a number was taken for a file descriptor (0: standard input, read and closed),
        # None or a NUL was a traceback, a named pipe nobody writes to was waited on
        self.path = file_argument(path, "path")
        kind = special_file(self.path)
        if kind is not None:
            raise InputError(f"{self.path}: cannot read: it is {kind}, not a file")
        self.readable = readable
        self.cut = True
        self.encodings: dict[str, str] = {}
        self.count = 0
        self.topics: frozenset[str] | None = None
        """The topics whose messages are given (``None``: every JSON channel's)."""
        self.foreign = False
        """The file's header names another library than pirate_bt (read at its start)."""
        self.indexed = False
        """Read in log-time order by the ``mcap`` library's indexed reader (:meth:`_indexed`)."""

    def __iter__(self) -> Iterator[tuple[str, dict[str, Any]]]:
        for _, topic, message in _by_sequence(self.timed()):
            yield topic, message

    def timed(self) -> Iterator[_Timed]:
        """The messages as ``(log_time, channel, sequence, topic, message)``: in file
        order from pirate_bt's own files (written in log-time order, read as they come),
        in log-time order from another tool's, whose header names another library: MCAP
        does not require a file in log-time order, and one written channel by channel was
        refused (*the first record is no header*). Another tool's file with an index is
        read by it (:meth:`_indexed`); one without (cut off, unchunked) is read as it
        comes too (:meth:`_merged`): once to find where its log times go back, then its
        stretches in log time merged (those of one time in file order; see
        :func:`_sequenced` for one channel's)."""
        runs = [0]  # where each stretch of non-decreasing log times starts
        last: int | None = None
        given = 0
        try:
            for item in self._file_order():
                if self.foreign and not self.indexed:
                    if last is not None and item[0] < last:
                        runs.append(given)
                    last = item[0]
                    given += 1
                else:
                    yield item
        except Exception:
            if given:  # what came before the damage, then the damage
                yield from self._merged(runs, given)
            raise
        if given:
            yield from self._merged(runs, given)

    def _merged(self, runs: list[int], given: int) -> Iterator[_Timed]:
        """The first ``given`` messages of another tool's file without an index, in
        log-time order (a stable sort: those of one time in file order), read again as
        they come: each stretch of non-decreasing log times (``runs``: where each starts)
        by a reader of its own, merged. Until 2026-12-01 the whole file was read into
        memory before its first message was given (every message decoded: many times
        the file). A file whose times go back more than :data:`MERGED_RUNS` times
        (shuffled) is read whole and sorted, as before."""
        self.count = 0
        if len(runs) > MERGED_RUNS:
            everything = list(itertools.islice(self._again()._file_order(), given))
            self.count = len(everything)
            yield from sorted(everything, key=lambda m: m[0])
            return
        ends = [*runs[1:], given]
        readings = [self._again()._file_order() for _ in runs]
        stretches = [
            itertools.islice(reading, start, end)
            for reading, start, end in zip(readings, runs, ends, strict=True)
        ]
        try:
            for item in heapq.merge(*stretches, key=lambda m: m[0]):  # stable
                self.count += 1
                yield item
        finally:
            for reading in readings:  # each closes its file
                with contextlib.suppress(Exception):
                    reading.close()

    def _again(self) -> _Messages:
        """A reader of the same file and topics, for one more reading."""
        again = _Messages(self.path, self.readable)
        again.topics = self.topics
        return again

    def _file_order(self) -> Generator[_Timed, None, None]:
        """The messages as ``(log_time, channel, sequence, topic, message)``, in file
        order."""
        load_mcap()
        from mcap.records import Channel, Footer, Header, Message
        from mcap.stream_reader import StreamReader

        try:
            stream = open(self.path, "rb")  # noqa: SIM115 (closed with the generator)
        except OSError as exc:
            raise InputError(f"{self.path}: cannot read: {exc.strerror or exc}") from None
        with stream:
            indexed = self._indexed(stream)
            if indexed is not None:
                yield from indexed
                return
            stream.seek(0)
            # CRCs checked: a damaged chunk read as garbage, or as a cut-off run
            records = StreamReader(stream, skip_magic=False, validate_crcs=True).records
            channels: dict[int, str] = {}
            number = 0
            while True:
                given: _Timed | None = None
                try:
                    record = next(records)  # the library reads a chunk when it needs one
                    if isinstance(record, Channel):
                        self.encodings.setdefault(record.topic, record.message_encoding)
                        if record.message_encoding == "json" and (
                            self.topics is None or record.topic in self.topics
                        ):
                            channels[record.id] = record.topic
                    elif isinstance(record, Message):
                        number += 1
                        topic = channels.get(record.channel_id)
                        if topic is not None:
                            message = _json_object(self.path, number, topic, record.data)
                            text = readable_text(message, record.data, self.readable)
                            given = (
                                record.log_time,
                                record.channel_id,
                                record.sequence,
                                topic,
                                text,
                            )
                    elif isinstance(record, Footer):
                        self.cut = False
                    elif isinstance(record, Header):
                        self.foreign = not record.library.startswith("pirate_bt")
                except StopIteration:
                    return
                except InputError:
                    raise
                except Exception as exc:  # the reader's, a decompressor's (zstd, lz4)
                    self._stopped(exc, stream, number)
                    return  # cut off: what came before it is the run
                if given is not None:
                    self.count += 1
                    yield given

    def _indexed(self, stream: IO[bytes]) -> Iterator[_Timed] | None:
        """Another tool's file with an index (chunks, a summary), in log-time order as
        the ``mcap`` library's indexed reader gives it: chunk by chunk, holding the chunks
        whose times overlap. Until 2026-11-30 another tool's file was read whole before
        its first record (its every message, decoded: a long run's trace written with
        foxglove-sdk grew the reader to many times the file). ``None``: pirate_bt's own
        file (read as it comes), or one with no index or no summary (cut off, unchunked,
        damaged, not MCAP: the stream reader reads it, and says what is wrong)."""
        from mcap.reader import SeekingReader

        try:
            reader = SeekingReader(stream, validate_crcs=True)
            if reader.get_header().library.startswith("pirate_bt"):
                return None
            summary = reader.get_summary()
        except Exception:  # the mcap library's, a decompressor's, an OSError
            return None
        if summary is None or not summary.chunk_indexes or not _channels_repeated(summary):
            return None
        self.foreign = self.indexed = True
        return self._by_index(reader, summary)

    def _by_index(self, reader: Any, summary: Any) -> Iterator[_Timed]:
        channels: dict[int, str] = {}
        for channel in summary.channels.values():
            self.encodings.setdefault(channel.topic, channel.message_encoding)
            if channel.message_encoding == "json" and (
                self.topics is None or channel.topic in self.topics
            ):
                channels[channel.id] = channel.topic
        messages = reader.iter_messages(topics=sorted(set(channels.values())))
        number = 0
        while True:
            try:
                _, _, record = next(messages)
            except StopIteration:
                break
            except Exception as exc:  # a damaged chunk (CRC, decompressor): no cut-off run
                raise InputError(
                    f"{self.path}: damaged after {number} message{'s' if number != 1 else ''}:"
                    f" {type(exc).__name__}: {exc}"
                ) from None
            number += 1
            topic = channels.get(record.channel_id)
            if topic is None:
                continue
            message = _json_object(self.path, number, topic, record.data)
            text = readable_text(message, record.data, self.readable)
            self.count += 1
            yield record.log_time, record.channel_id, record.sequence, topic, text
        self.cut = False

    def _stopped(self, exc: Exception, stream: IO[bytes], number: int) -> None:
        """Raise the error of the reading stopped by ``exc``, unless the file was cut
        off there (the run was killed)."""
        from mcap.exceptions import McapError

        path = self.path
        try:
            if not self.count and not self.encodings:
                # a file cut inside its magic or first chunk says nothing of its own
                reason = str(exc) if isinstance(exc, McapError) and str(exc) else ""
                size = os.fstat(stream.fileno()).st_size
                _refuse_renamed(path, os.pread(stream.fileno(), 2, 0))
                raise InputError(
                    f"{path}: not a readable MCAP file"
                    + (f": {reason}" if reason else f" (cut off or damaged: {size} bytes)")
                ) from None
            cut = _cut_off(exc, stream)
        except OSError as error:
            raise InputError(f"{path}: cannot read: {error.strerror or error}") from None
        if not cut:  # damage before the end is no cut-off run
            raise InputError(
                f"{path}: damaged after {number} message{'s' if number != 1 else ''}:"
                f" {type(exc).__name__}: {exc}"
            ) from None


def _channels_repeated(summary: Any) -> bool:
    """Whether a summary repeats every channel of the file and every schema of those:
    the ``mcap`` library's indexed reader takes them from there. The MCAP spec leaves
    repeating them to the writer (the ``mcap`` library's ``Writer(repeat_channels=False)``,
    other writers' options); until 2026-12-01 a valid file written so was refused as
    *damaged after 0 messages: KeyError: 1*. Such a file is read as it comes (its
    Channel and Schema records are in its data section)."""
    channels = summary.channels
    if not channels:
        return False
    statistics = summary.statistics
    if statistics is not None and statistics.channel_count > len(channels):
        return False
    named = {channel for index in summary.chunk_indexes for channel in index.message_index_offsets}
    if not named <= channels.keys():
        return False
    return all(c.schema_id == 0 or c.schema_id in summary.schemas for c in channels.values())


_RENAMED = {b"{": ("a JSON Lines", ".jsonl"), b"\x1f\x8b": ("a gzip-compressed", ".jsonl.gz")}


def _refuse_renamed(path: str | Path, start: bytes) -> None:
    """A ``.jsonl`` or ``.jsonl.gz`` trace renamed ``.mcap`` is named as one (it was
    *not a valid MCAP file, invalid magic: (123, 34, 116, ...)*), as the ``.jsonl``
    reader names an MCAP or gzip trace renamed ``.jsonl``."""
    for magic, (kind, suffix) in _RENAMED.items():
        if start.startswith(magic):
            name = Path(path)
            raise InputError(f"{path}: {kind} trace, not MCAP: name it {name.stem}{suffix}")


def _json_object(path: str | Path, number: int, topic: str, data: bytes) -> dict[str, Any]:
    """A JSON channel's message, whole (the stream reader read all its bytes): damage
    inside it is named, where it used to end the reading as if the run was cut off."""
    try:
        message = json.loads(data)
    except ValueError as exc:  # JSONDecodeError, UnicodeDecodeError
        raise InputError(f"{path}: message {number} (on {topic}) is not JSON: {exc}") from None
    if not isinstance(message, dict):
        raise InputError(
            f"{path}: message {number} (on {topic}) is JSON {type(message).__name__}, not an object"
        )
    return message


class _TraceMessages(_Messages):
    """:class:`_Messages` of a file that should hold a pirate_bt trace.

    Raises:
        InputError: as :func:`read_mcap_messages`, and a file with no JSON
            ``/pirate/run`` channel (another tool's recording, JSON or not, a rosbag2
            bag's MCAP), once it is read through.
    """

    def __init__(self, path: str | Path, readable: bool = False) -> None:
        super().__init__(path, readable)
        # Another tool's channels beside the trace's are not read: a JSON one whose
        # message was no object (a list) refused the whole trace.
        self.topics = frozenset(TOPICS)

    def timed(self) -> Iterator[_Timed]:
        yield from super().timed()
        encodings = self.encodings
        if encodings.get(RUN) != "json" and (encodings or not self.cut):
            # (a file cut before its channels is a run cut off at its start: said later;
            # another tool's JSON messages were read as an "empty trace (no header)")
            listed = ", ".join(f"{topic} ({encodings[topic]})" for topic in sorted(encodings)[:6])
            more = ", ..." if len(encodings) > 6 else ""
            hint = ""
            if "cdr" in encodings.values():
                hint = (
                    "; a rosbag2 bag's trace is read by"
                    " pirate_bt.interop.rosbag2.read_rosbag2_records"
                )
            raise InputError(
                f"{self.path}: not a pirate_bt trace: no JSON {RUN} channel"
                + (f" (its channels: {listed}{more})" if listed else "")
                + hint
            )


def read_mcap_records(path: str | Path) -> list[dict[str, Any]]:
    """The trace records an MCAP file written by pirate_bt holds (see :func:`export_mcap`).

    Raises:
        InputError: as :func:`read_mcap_messages`, and a file that holds no pirate_bt
            trace.
    """
    return list(records_from_messages(_in_order(_TraceMessages(path).timed())))


class McapTraceReader(TraceFormatReader):
    """Reads a pirate_bt MCAP file back as trace records (registered for ``.mcap``).

    Records are numbered from 1 in order (an MCAP file has no lines). They are
    given as the file is read, chunk by chunk; ``truncated`` is set once they have
    all been given.
    """

    suffixes: ClassVar[tuple[str, ...]] = (".mcap",)

    def __iter__(self) -> Iterator[tuple[int, dict[str, Any]]]:
        # read_trace's text as shown: half a UTF-16 pair ("\ud800") in a name was an
        # internal error printing it, as it was for a .jsonl trace
        messages = _TraceMessages(self.path, self.readable)
        yield from enumerate(records_from_messages(_in_order(messages.timed())), start=1)
        self.truncated = messages.cut


def register() -> None:
    """Register ``.mcap`` with :mod:`pirate_bt.trace`'s writers and readers.

    Called when this module is imported, and by the ``pirate_bt.trace_formats``
    entry point; calling it again changes nothing.
    """
    for suffix in McapTraceReader.suffixes:
        register_reader(suffix, McapTraceReader)
    for suffix in McapTraceWriter.suffixes:
        register_writer(suffix, McapTraceWriter)
    register_process_writer(McapTraceWriter)  # a recorder writes it from its writer process


register()
