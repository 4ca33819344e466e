"""The trace's format writers by file suffix: :data:`WRITERS`, :func:`register_writer`,
:func:`open_writer`.

Split out of :mod:`pirate_bt.trace.writer`, which re-exports every name here. A
format writer (:class:`~pirate_bt.trace.sink.JsonLinesWriter`,
:class:`~pirate_bt.trace.sink.GzipJsonLinesWriter`) knows about bytes; this table
says which one writes a file, by the longest suffix of its name that it lists, so
another format is one class and one :func:`register_writer` call (formats above
this package, such as MCAP, register themselves: see :mod:`pirate_bt.trace.formats`).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from pirate_bt.trace.formats import register_format, suffix_of
from pirate_bt.trace.sink import GzipJsonLinesWriter, JsonLinesWriter, TraceFormatWriter

__all__ = ["WRITERS", "WriterFactory", "open_writer", "register_writer"]


WriterFactory = Callable[..., TraceFormatWriter]
"""Opens the writer of one file, called as ``factory(path, sync=sync)``: a
:class:`TraceFormatWriter` subclass, or a callable."""

#: File suffix -> format writer (a class, or a callable that opens one); the longest
#: matching suffix wins. Add rows with :func:`register_writer`; ``.mcap`` is
#: registered by :mod:`pirate_bt.interop.mcap_trace` (through the
#: ``pirate_bt.trace_formats`` entry points, loaded the first time a suffix is not
#: found here).
WRITERS: dict[str, WriterFactory] = {
    suffix: cls for cls in (JsonLinesWriter, GzipJsonLinesWriter) for suffix in cls.suffixes
}


def register_writer(suffix: str, factory: WriterFactory, *, replace: bool = False) -> None:
    """Write files whose name ends with ``suffix`` with ``factory(path, sync=sync)``.

    ``factory`` returns an open :class:`TraceFormatWriter`, which receives each
    record as one line of JSON text (``write_line``) and is closed at the end. A
    registered writer runs in the recording process (the trace's writer process
    knows only the built-in formats). Registering the same factory twice is a
    no-op. Example::

        class Bz2TraceWriter(TraceFormatWriter):  # JSON Lines, bzip2-compressed
            def _open(self, fd):
                return bz2.open(self.path, "wb")

        register_writer(".jsonl.bz2", Bz2TraceWriter)
        TraceRecorder("run.jsonl.bz2", tree)

    Raises:
        ValueError: ``suffix`` does not start with a dot, or another factory has
            it (unless ``replace``).
    """
    register_format(WRITERS, suffix, factory, replace=replace)


def open_writer(path: str | Path, sync: bool = False) -> TraceFormatWriter:
    """A format writer for ``path``, chosen by its suffix (see :data:`WRITERS`).

    Raises:
        InputError: unknown suffix (the message lists the known ones).
        ConfigurationError: the suffix needs an optional part that is not installed.
    """
    return WRITERS[suffix_of(path, WRITERS)](path, sync=sync)
