"""The format writers of traces: the file formats a trace record is written in.

Split out of :mod:`pirate_bt.trace.sink` (which re-exports every name here):
:class:`TraceFormatWriter` and the two formats a writer process can run,
:class:`JsonLinesWriter` and :class:`GzipJsonLinesWriter` (:data:`WRITER_CLASSES`),
and how a writer process finds a registered one (:func:`register_process_writer`,
:func:`writer_spec`, :func:`load_writer`).
Other formats (MCAP) subclass :class:`TraceFormatWriter` elsewhere and run
in-process, or in a writer process once registered with
:func:`pirate_bt.trace.sink.register_process_writer`.

Like the rest of the writer process, this module needs only the standard library;
from ``pirate_bt`` it imports only :mod:`pirate_bt.trace.sink_encode`.
"""

from __future__ import annotations

import contextlib
import errno
import gzip
import os
import stat
import sys
import weakref
import zlib
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import IO, Any, ClassVar, cast

from pirate_bt.trace.sink_encode import encode_json

__all__ = [
    "WRITER_CLASSES",
    "GzipJsonLinesWriter",
    "JsonLinesWriter",
    "TraceBusyError",
    "TraceFormatWriter",
    "claim",
    "forget_in_forks",
    "held",
    "let_go_in_forks",
    "load_writer",
    "register_process_writer",
    "to_null",
    "writer_spec",
]


BUSY = (
    "another run is writing it (a trace holds one run); name another file,"
    " or wait until that run has ended"
)
"""Why :func:`claim` refuses a file (the strerror of :class:`TraceBusyError`)."""


class TraceBusyError(BlockingIOError):
    """A trace file that another writer holds (:func:`claim`); nothing of it was changed."""


def claim(path: Path, truncate: bool) -> int:
    """Open ``path`` for writing (created if missing) and take it for one writer.

    Two runs writing one trace at once (``simulate_tree(..., trace="same.jsonl")`` in
    three threads or processes) mixed their lines into a file no reader could read,
    each truncating what the others had written. A writer takes an exclusive advisory
    lock (``flock``) on the file's open description before it truncates: the lock
    goes with the descriptor into the writer process and lasts until the last writer
    of the run closes the file, even when the recording process was killed. A second
    writer of the same file (by any name: a symbolic or hard link is the same file)
    is refused before it changes a byte of it. A file that is not a regular one (a
    device, a named pipe something reads) is not locked; where ``flock`` does not exist
    or the file system refuses it, the file is written as before. A named pipe nobody
    reads is refused at once (``ENXIO``: *it is a named pipe nobody reads, not a file*),
    never waited on.

    Args:
        path: The trace file.
        truncate: Empty it once it is taken (a writer that opens it again itself,
            with ``"wb"``, does not need this).

    Returns:
        The open descriptor; the lock lasts while it (or a copy) is open.

    Raises:
        TraceBusyError: another writer holds the file.
        OSError: it cannot be opened.
    """
    try:
        # never waits: a named pipe nobody reads (made at the path after the run's
        # checks) held the run at its start for ever; O_NONBLOCK refuses it at once
        fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_NONBLOCK, 0o666)
    except OSError as exc:
        if exc.errno == errno.ENXIO:  # a named pipe nobody reads, or a socket
            raise OSError(errno.ENXIO, _not_a_file(path), str(path)) from None
        raise
    try:
        os.set_blocking(fd, True)  # written as before (a pipe that has a reader, a device)
        if stat.S_ISREG(os.fstat(fd).st_mode):
            try:
                import fcntl

                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                raise TraceBusyError(errno.EWOULDBLOCK, BUSY, str(path)) from None
            except (ImportError, OSError):  # no flock here: written as before
                pass
            if truncate:
                os.ftruncate(fd, 0)
    except BaseException:
        os.close(fd)
        raise
    return fd


def _not_a_file(path: Path) -> str:
    """Why :func:`claim` cannot open ``path`` for writing without waiting."""
    try:
        mode = os.stat(path).st_mode
    except OSError:
        mode = 0
    if stat.S_ISSOCK(mode):
        return "it is a socket, not a file"
    if stat.S_ISFIFO(mode):
        return "it is a named pipe nobody reads, not a file"
    return os.strerror(errno.ENXIO)


def held(path: str | os.PathLike[str]) -> bool:
    """Whether another writer holds ``path`` now (:func:`claim` would refuse it).

    A look that changes nothing, for a check before a run connects; the writer's own
    :func:`claim` still decides (a run may take the file in between).
    """
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK)  # no wait for a pipe's writer
    except OSError:
        return False
    try:
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            return False
        import fcntl

        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        return True
    except (ImportError, OSError):
        return False
    finally:
        os.close(fd)  # and with it the lock taken to look
    return False


_OURS: weakref.WeakSet[Any] = weakref.WeakSet()
"""What holds a trace open in this process (writers, writer processes' pipes)."""


def let_go_in_forks(holder: Any) -> None:
    """Have a process forked from this one let go of ``holder``'s trace (its ``_forked``).

    A process forked without ``exec`` (``multiprocessing``'s ``fork`` start method, a
    planner's ``os.fork``) got a copy of every descriptor, and with the copy of a
    claimed one a share in its ``flock``: once the run had ended, another run was
    refused the trace (*another run is writing it*) for as long as the child lived,
    and a run killed meanwhile left its writer process waiting for the end of a pipe
    the child still held. In the child, ``holder._forked()`` points its descriptors at
    ``/dev/null`` (the numbers stay taken, so nothing else is written through them)
    and makes its ``close`` leave the trace alone: the trace is its run's, in the
    process that made the writer.
    """
    _OURS.add(holder)


def forget_in_forks(holder: Any) -> None:
    """``holder`` has closed its trace: a process forked from now on leaves it alone.
    Its descriptors' numbers may be another's by then (a process pool's pipe: pointed
    at ``/dev/null`` in the pool's forked worker, the pool's results went nowhere and
    the campaign waited for ever)."""
    _OURS.discard(holder)


def _let_go() -> None:
    """In a forked child: let go of every trace this process's parent holds."""
    for holder in list(_OURS):
        with contextlib.suppress(OSError, ValueError):  # ValueError: a file with no descriptor
            holder._forked()
    _OURS.clear()


def to_null(*fds: int) -> None:
    """Point the descriptors ``fds`` (those still open) at ``/dev/null``."""
    null = os.open(os.devnull, os.O_RDWR)
    try:
        for fd in fds:
            try:
                os.fstat(fd)
            except OSError:
                continue  # closed already
            os.dup2(null, fd, inheritable=False)
    finally:
        os.close(null)


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_let_go)


class TraceFormatWriter:
    """Writes trace records to a file in one format; subclasses implement ``_open``.

    Opened without ``fd``, the file is first taken for this writer (:func:`claim`):
    a file another writer holds raises :class:`TraceBusyError`, and is left as it was.

    Args:
        path: Where to write (created or truncated).
        sync: Also ``fsync`` after every record, for power loss (slower).
        fd: An open file descriptor for ``path`` to write to instead of opening it
            (already taken, as a writer process's is).
    """

    suffixes: ClassVar[tuple[str, ...]] = ()

    def __init__(self, path: str | Path, sync: bool = False, fd: int | None = None) -> None:
        self.path = Path(path)
        self.sync = sync
        self._claim: IO[bytes] | None = None
        if fd is None:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            # its own descriptor: a subclass's _open may open the path itself
            self._claim = open(claim(self.path, truncate=False), "wb", buffering=0)  # noqa: SIM115
        try:
            self._file = self._open(fd)
        except BaseException:
            self._release()
            raise
        let_go_in_forks(self)

    def _forked(self) -> None:
        """In a process forked from this writer's: let go of the file (see
        :func:`let_go_in_forks`); what this copy writes goes nowhere."""
        held = getattr(self, "_claim", None)
        fds = [] if held is None or held.closed else [held.fileno()]
        file = getattr(self, "_file", None)
        if file is not None and not file.closed:
            fds.append(file.fileno())
        to_null(*fds)

    def _release(self) -> None:
        held = getattr(self, "_claim", None)  # (a subclass may not call __init__)
        if held is not None and not held.closed:
            held.close()

    def _open(self, fd: int | None) -> IO[bytes]:
        raise NotImplementedError

    def _claimed(self) -> int | None:
        """A new descriptor of the file :func:`claim` took for this writer, emptied (a
        regular file), or ``None`` (given ``fd``). A format's ``_open`` writes there
        rather than opening the path again: another file may be there by then (a named
        pipe made after the run's checks was waited on for ever)."""
        held = self._claim
        if held is None or held.closed:
            return None
        fd = os.dup(held.fileno())
        try:
            if stat.S_ISREG(os.fstat(fd).st_mode):
                os.ftruncate(fd, 0)
        except BaseException:
            os.close(fd)
            raise
        return fd

    @classmethod
    def preflight(cls, path: Path) -> None:
        """Raise what would stop this writer from opening ``path``, in the recording process.

        Called before a writer process is started for it, so that a missing optional
        package is one clear error there; the default checks nothing.
        """

    def cut_off(self) -> None:
        """The records ended without an end record (the run was killed); ``close`` follows.

        A writer process calls this when its input closes early. The default does
        nothing: what was written stays as it is.
        """

    def _flush(self) -> None:
        self._file.flush()

    def write(self, record: Mapping[str, Any]) -> None:
        """Write one record as one line and flush it to the operating system."""
        self.write_line(encode_json(record) + "\n")

    def write_line(self, line: str) -> None:
        """Write one record given as its JSON text, ``\\n``-terminated, and flush it.

        The recorder hands tick records over this way (it assembles their text
        directly). A writer of a format that is not JSON text overrides this to
        decode the line (``json.loads``) and store the record its own way.
        """
        self._file.write(line.encode("utf-8", "backslashreplace"))
        self._flush()
        if self.sync:
            os.fsync(self._file.fileno())

    def write_lines(self, lines: list[str]) -> None:
        """Write several records given as their JSON text (the writer process's batches).

        The default writes each with :meth:`write_line`; a format that can write a batch
        at once (:class:`JsonLinesWriter`) overrides this.
        """
        for line in lines:
            self.write_line(line)

    def close(self) -> None:
        """Flush and close the file (idempotent); another writer may take it then."""
        try:
            if not self._file.closed:
                self._file.close()
        finally:
            self._release()
            forget_in_forks(self)


class JsonLinesWriter(TraceFormatWriter):
    """Plain JSON Lines (``.jsonl``); each line goes to the kernel with one ``os.write``."""

    suffixes = (".jsonl", ".ndjson")

    def _open(self, fd: int | None) -> IO[bytes]:
        # Unbuffered: each record goes to the kernel in write(), nothing waits in Python.
        if fd is None:
            fd = self._claimed()
        if fd is not None:
            return open(fd, "wb", buffering=0)
        return open(self.path, "wb", buffering=0)

    def write_line(self, line: str) -> None:
        """Write one line with one ``os.write`` (the kernel has it on return)."""
        data = line.encode("utf-8", "backslashreplace")
        fd = self._file.fileno()
        written = os.write(fd, data)
        while written < len(data):  # a regular file takes it all; a pipe or a full disk may not
            written += os.write(fd, data[written:])
        if self.sync:
            os.fsync(fd)

    def write_lines(self, lines: list[str]) -> None:
        """Write the lines with one ``os.write`` (``sync``: one each, each fsynced)."""
        if self.sync or len(lines) == 1:
            for line in lines:
                self.write_line(line)
        elif lines:
            self.write_line("".join(lines))


class GzipJsonLinesWriter(TraceFormatWriter):
    """Gzip-compressed JSON Lines (``.jsonl.gz``), sync-flushed per record.

    A sync flush ends each record on a byte boundary of the deflate stream, so a
    killed run still decompresses up to its last complete tick.
    """

    suffixes = (".jsonl.gz",)

    def _open(self, fd: int | None) -> IO[bytes]:
        if fd is None:
            fd = self._claimed()
        if fd is not None:
            self._raw = open(fd, "wb")  # noqa: SIM115 - closed by close()
        else:
            self._raw = open(self.path, "wb")  # noqa: SIM115 - closed by close()
        return cast(IO[bytes], gzip.GzipFile(fileobj=self._raw, mode="wb", compresslevel=6))

    def _flush(self) -> None:
        assert isinstance(self._file, gzip.GzipFile)
        self._file.flush(zlib.Z_SYNC_FLUSH)
        self._raw.flush()

    def close(self) -> None:
        super().close()
        if not self._raw.closed:
            self._raw.close()


WRITER_CLASSES: dict[str, type[TraceFormatWriter]] = {
    cls.__name__: cls for cls in (JsonLinesWriter, GzipJsonLinesWriter)
}
"""The format writers a writer process can run, by class name."""


def register_process_writer(cls: type[TraceFormatWriter]) -> None:
    """Let writer processes run ``cls`` (a recorder then uses one for its suffixes).

    ``cls``'s module is imported by name in the writer process (see
    :mod:`pirate_bt.trace.sink` for what it may import). Registering it again
    changes nothing.
    """
    WRITER_CLASSES[cls.__name__] = cls


def writer_spec(cls: type[TraceFormatWriter]) -> str:
    """How the writer process finds ``cls``: its name, or ``module:name`` from elsewhere."""
    if cls.__module__ == TraceFormatWriter.__module__:
        return cls.__name__
    return f"{cls.__module__}:{cls.__qualname__}"


def load_writer(spec: str, paths: Sequence[str]) -> type[TraceFormatWriter]:
    """The writer class named by :func:`writer_spec`, imported behind stand-in packages
    (in the writer process, with the recording process's ``paths`` after its own)."""
    module_name, colon, name = spec.partition(":")
    if not colon:
        return WRITER_CLASSES[spec]
    import importlib
    import types

    sys.path.extend(p for p in paths if p not in sys.path)  # after the standard library
    top = Path(__file__).resolve().parent.parent
    parts = module_name.split(".")
    for depth in range(1, len(parts)):
        package = ".".join(parts[:depth])
        if package not in sys.modules and parts[0] == "pirate_bt":
            stand_in = types.ModuleType(package)
            stand_in.__path__ = [str(top.joinpath(*parts[1:depth]))]
            sys.modules[package] = stand_in
    cls = getattr(importlib.import_module(module_name), name)
    if not (isinstance(cls, type) and issubclass(cls, TraceFormatWriter)):
        raise ValueError(f"{spec} is no trace format writer")
    return cls
