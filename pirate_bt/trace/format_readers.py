"""The trace file formats: a reader per suffix, each yielding checked records.

A :class:`TraceFormatReader` yields ``(line_number, record)`` pairs from one file;
:data:`READERS` maps a suffix to its reader and :func:`register_reader` adds one
(formats above this package register themselves, see :mod:`pirate_bt.trace.formats`).
Every record a reader yields is checked on the way (a header's tree, a tick record:
:func:`tick_record`), whoever iterates it. :mod:`pirate_bt.trace.reader` builds a
:class:`~pirate_bt.trace.reader.Trace` from these records and re-exports this module's
names.
"""

from __future__ import annotations

import gzip
import json
import sys
import zlib
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import IO, Any, ClassVar

from pirate_bt.errors import InputError, LocatedError, SourceLocation
from pirate_bt.trace import record_values as values
from pirate_bt.trace.formats import refuse_folder, register_format, suffix_of
from pirate_bt.trace.gzip_text import open_gzip_text
from pirate_bt.trace.header_check import checked_iteration
from pirate_bt.trace.records import objects, status_codes
from pirate_bt.yamlfile import special_file

__all__ = [
    "MAX_HEADER_BYTES",
    "MAX_LINE_BYTES",
    "READERS",
    "GzipJsonLinesReader",
    "JsonLinesReader",
    "ReaderFactory",
    "TickRecord",
    "TraceFormatReader",
    "open_reader",
    "register_reader",
    "tick_record",
]


MAX_LINE_BYTES = 16 * 1024 * 1024
"""The longest tick or end line of a JSON Lines trace. A longer line is no trace's."""

MAX_HEADER_BYTES = 256 * 1024 * 1024
"""The longest header line: it holds the tree, up to 100,000 nodes 100 deep, each
with its path id, parent and children (a tree of 91,000 nodes 90 deep writes 38 MB;
the header was held to 16 MiB and such a trace refused as 'not a trace')."""


def _bounded_lines(stream: IO[bytes]) -> Iterator[bytes]:
    """The lines of ``stream``, each read at most its limit + 1 long."""
    limit = MAX_HEADER_BYTES
    while line := stream.readline(limit + 1):
        yield line
        limit = MAX_LINE_BYTES


def _check_tick(record: Mapping[str, Any], line: int, where: Path) -> None:
    tick_record(record, line, where)


class TraceFormatReader:
    """Yields ``(line_number, record)`` from a trace file; subclasses implement ``_open``.

    Whatever iterates a reader gets checked records (a subclass's own ``__iter__``
    too): a header's tree that is no tree, or a bad tick record, is a
    :class:`~pirate_bt.errors.LocatedError` (see :mod:`pirate_bt.trace.header_check`).

    Args:
        path: The trace file.
    """

    suffixes: ClassVar[tuple[str, ...]] = ()

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        own = cls.__dict__.get("__iter__")
        if own is not None and not hasattr(own, "__unchecked__"):
            cls.__iter__ = checked_iteration(own, _check_tick)  # type: ignore[method-assign]

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self.truncated = False
        self.readable = False  # read_trace's: text as shown (see readable_text)

    def _open(self) -> IO[bytes]:
        raise NotImplementedError

    def _lines(self, stream: IO[bytes]) -> Iterator[bytes]:
        yield from _bounded_lines(stream)

    @partial(checked_iteration, tick=_check_tick)
    def __iter__(self) -> Iterator[tuple[int, dict[str, Any]]]:
        kind = special_file(self.path)  # a named pipe nobody writes to: waited on for ever
        if kind is not None:
            raise InputError(f"{self.path}: cannot read trace: it is {kind}, not a file")
        try:
            stream = self._open()
        except OSError as exc:
            raise InputError(f"{self.path}: cannot read trace: {exc.strerror or exc}") from None
        with stream:
            pending: tuple[int, bytes] | None = None
            for number, line in enumerate(self._lines(stream), start=1):
                if len(line) > (limit := MAX_HEADER_BYTES if number == 1 else MAX_LINE_BYTES):
                    raise LocatedError(
                        f"a line longer than {limit} bytes: not a trace",
                        SourceLocation(str(self.path), number),
                    )
                if pending is not None:
                    yield pending[0], self._decode(*pending, last=False)
                pending = (number, line)
            if pending is not None:
                number, line = pending
                if line.strip():
                    try:
                        yield number, self._decode(number, line, last=True)
                    except _CutOff:
                        self.truncated = True

    def _decode(self, number: int, line: bytes, last: bool) -> dict[str, Any]:
        try:
            record = values.readable_text(json.loads(line.rstrip(b"\r\n")), line, self.readable)
        except (json.JSONDecodeError, UnicodeDecodeError) as exc:
            if last and not line.endswith(b"\n"):
                raise _CutOff from None
            column = getattr(exc, "colno", None) or getattr(exc, "start", 0) + 1
            raise LocatedError(
                f"not a trace record: {getattr(exc, 'msg', exc)}",
                SourceLocation(str(self.path), number, column),
            ) from None
        except (ValueError, RecursionError) as exc:  # valid JSON Python's json cannot hold
            raise LocatedError(
                f"not a trace record: {_beyond_json(exc)}", SourceLocation(str(self.path), number)
            ) from None
        if not isinstance(record, dict) or not isinstance(record.get("type"), str):
            raise LocatedError(
                "not a trace record: expected a JSON object with a 'type'",
                SourceLocation(str(self.path), number),
            )
        return record


def _beyond_json(exc: ValueError | RecursionError) -> str:
    """What a line of valid JSON holds that no trace does, in a user's words."""
    if isinstance(exc, RecursionError):
        return "values nested deeper than a trace's reader goes"
    if "integer string conversion" in str(exc):
        return f"a whole number longer than {sys.get_int_max_str_digits()} digits"
    return str(exc)


class _CutOff(Exception):
    """The last line of a file was cut off mid-record."""


class JsonLinesReader(TraceFormatReader):
    """Reads plain JSON Lines traces (``.jsonl``)."""

    suffixes = (".jsonl", ".ndjson")

    def _open(self) -> IO[bytes]:
        return values.opened_as_text(self.path)  # a gzip or MCAP trace is named so


class GzipJsonLinesReader(TraceFormatReader):
    """Reads gzip-compressed JSON Lines traces (``.jsonl.gz``), even if cut off."""

    suffixes = (".jsonl.gz",)

    def _open(self) -> IO[bytes]:
        values.refuse_not_gzip(self.path)  # renamed: the name to give it
        return open_gzip_text(self.path)  # loses less to damage than gzip.open

    def _lines(self, stream: IO[bytes]) -> Iterator[bytes]:
        number = 0
        try:
            for number, line in enumerate(_bounded_lines(stream), start=1):  # noqa: B007
                yield line
        except EOFError:
            # A killed writer leaves no gzip trailer; everything flushed is intact.
            self.truncated = True
        except (zlib.error, gzip.BadGzipFile) as exc:
            # Not a cut (that is an EOFError) but damage: bytes changed, or not gzip.
            raise LocatedError(
                f"not readable as gzip after {number} lines: {exc}",
                SourceLocation(str(self.path), number + 1),
            ) from None


ReaderFactory = Callable[[str | Path], TraceFormatReader]
"""Makes the reader of one file: a :class:`TraceFormatReader` subclass, or a callable."""

#: File suffix -> reader (a class, or a callable that makes one); the longest suffix wins.
#: Add rows with :func:`register_reader`; ``.mcap`` is registered by
#: :mod:`pirate_bt.interop.mcap_trace` (through the ``pirate_bt.trace_formats``
#: entry points, loaded the first time a suffix is not found here).
READERS: dict[str, ReaderFactory] = {
    suffix: cls for cls in (JsonLinesReader, GzipJsonLinesReader) for suffix in cls.suffixes
}


def register_reader(suffix: str, factory: ReaderFactory, *, replace: bool = False) -> None:
    """Read files whose name ends with ``suffix`` with ``factory(path)``.

    ``factory`` returns a :class:`TraceFormatReader`: an iterable of
    ``(number, record)`` pairs, the records being the JSON objects of
    ``docs/formats/trace.md``, which sets ``truncated`` if the file was cut off.
    Registering the same factory twice is a no-op. Example::

        class Bz2TraceReader(TraceFormatReader):  # JSON Lines, bzip2-compressed
            def _open(self):
                return bz2.open(self.path, "rb")

        register_reader(".jsonl.bz2", Bz2TraceReader)
        read_trace("run.jsonl.bz2")

    A reader of a format that is not JSON Lines overrides ``__iter__`` instead.

    Raises:
        ValueError: ``suffix`` does not start with a dot, or another factory has
            it (unless ``replace``).
    """
    register_format(READERS, suffix, factory, replace=replace)


def open_reader(path: str | Path) -> TraceFormatReader:
    """A format reader for ``path``, chosen by its suffix (see :data:`READERS`).

    Raises:
        InputError: unknown suffix (the message lists the known ones).
        ConfigurationError: the suffix needs an optional part that is not installed.
    """
    refuse_folder(path)
    factory = READERS[suffix_of(path, READERS)]
    # for every format: an .mcap reader (its own __iter__) opened a named pipe and
    # waited on it for ever
    kind = special_file(Path(path))
    if kind is not None:
        raise InputError(f"{path}: cannot read trace: it is {kind}, not a file")
    return factory(path)


@dataclass(frozen=True)
class TickRecord:
    """One ``tick`` record as stored: only what changed (see the writer's docstring)."""

    n: int
    t_s: float
    status: Mapping[str, str] = field(default_factory=dict)
    feedback: Mapping[str, str] = field(default_factory=dict)
    bb: Mapping[str, Any] = field(default_factory=dict)
    bb_unset: tuple[str, ...] = ()
    state: Mapping[str, Any] = field(default_factory=dict)
    full: bool = False
    commands: tuple[Mapping[str, Any], ...] = ()
    link: Mapping[str, Any] = field(default_factory=dict)
    sim: Mapping[str, Any] = field(default_factory=dict)
    events: tuple[Mapping[str, Any], ...] = ()
    line: int = 0


def tick_record(record: Mapping[str, Any], line: int, where: Path) -> TickRecord:
    """A ``tick`` record as a :class:`TickRecord`, checked.

    Raises:
        LocatedError: a field of the wrong kind, at ``where``'s ``line``.
    """
    if (problem := values.tick_values_problem(record)) is not None:
        raise LocatedError(f"bad tick record: {problem}", SourceLocation(str(where), line))
    try:
        return TickRecord(
            n=int(record["n"]),
            t_s=float(record["t_s"]),
            status=status_codes(record.get("status", {})),
            feedback=dict(record.get("feedback", {})),
            bb=dict(record.get("bb", {})),
            bb_unset=tuple(record.get("bb_unset", ())),
            state=dict(record.get("state", {})),
            full=bool(record.get("full", False)),
            commands=objects(record.get("commands", ()), "commands"),
            link=dict(record.get("link", {})),
            sim=dict(record.get("sim", {})),
            events=tuple(record.get("events", ())),
            line=line,
        )
    except (KeyError, TypeError, ValueError) as exc:
        raise LocatedError(
            f"bad tick record: {type(exc).__name__}: {exc}", SourceLocation(str(where), line)
        ) from None
