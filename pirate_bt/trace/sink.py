"""The half of the trace writer that needs only the standard library.

:class:`~pirate_bt.trace.TraceRecorder` is split in two, so that the tick pays
for as little as possible:

- **Capture** (``writer.py``, in the tick's thread): read every node's status and
  feedback message, the blackboard, and the raw values of the robot state, link
  health and simulator counters; keep only what moved; hand that over as one
  small tuple of plain values (a *message*, below).
- **Encode and write** (this module and its two siblings): compare the values with what was last
  recorded, round them, assemble the tick record's JSON text and write it as one
  line. :class:`TickEncoder` does the first part and the format writers
  (:class:`JsonLinesWriter`, :class:`GzipJsonLinesWriter`) the second.

By default the second half runs in a **writer process** (:class:`SinkProcess`,
this file run as a script): the recorder ``marshal``\\s each message and hands it
over, and the writer process encodes, compresses and writes while the robot's
process goes on with the next tick. Ticks go through a ring of shared memory
(:mod:`pirate_bt.trace.sink_ring`, on Linux), the other messages and the ring's
bells through a pipe (the only way elsewhere). Crash safety is kept: a message is
in memory the kernel keeps for the writer process (the ring, or the pipe's
buffer) once :meth:`SinkProcess.send` returns, and the writer process outlives
the recorder's process, so a run killed with SIGKILL still has every tick it
handed over written out (the writer sees the pipe close, writes what is left in
the pipe and the ring, and exits). The writer process runs in its own session, so
a signal to the run's process group does not stop it either. With
``background=False``, or for a format writer this module does not know, the same
:class:`TickEncoder` runs in-process.

Messages (tuples; the first item says which):

``(SETUP, node_ids, every_tick, full_state, readings, link_fields)``
    Once, first. Node ids in depth-first order; the status and feedback changes
    of ticks refer to nodes by index into this list. ``link_fields`` names the
    items of the link-health tuples.
``(LINE, text)``
    A whole record, already encoded (the header; the end record in-process).
``(END, text)``
    The end record, already encoded: the writer process writes it, closes the file
    and exits at once (the pipe closing without it means the run was cut off).
``(BELL, position)``
    The ring holds messages up to ``position`` (bytes ever written to it): the
    writer process takes them out before it reads on.
``(TICK, n, t_s, status, feedback, bb, state_keys, state_raw, commands, link, sim, events)``
    One tick: ``t_s`` is the seconds since the header (not yet rounded),
    ``status`` a list of ``(index, code)``, ``feedback`` a list of
    ``(index, message)``, ``bb`` and ``events`` the JSON members already
    encoded (``,"bb":{...}``), ``state_keys``/``state_raw`` the state's layout
    (``None`` when unchanged) and raw values (``None`` when not given or
    unchanged), ``commands`` a list of JSON texts, ``link`` the raw link-health
    tuple and ``sim`` the counters (``None`` when unchanged or not given).

On the pipe and in the ring each message is a 4-byte little-endian length and
its ``marshal`` bytes (:func:`frame`, :func:`unframe`; the live outputs of
:mod:`pirate_bt.interop` frame their pipes the same way). This module and the
four it is split into import nothing outside the standard library and nothing
else from ``pirate_bt``, so the writer process starts in a few milliseconds. The seams:

- :mod:`pirate_bt.trace.sink_encode`: how values are rounded and spelled, the
  state diff and the other change trackers, :class:`TickEncoder`.
- :mod:`pirate_bt.trace.sink_formats`: the format writers, :data:`WRITER_CLASSES`,
  :func:`register_process_writer`.
- :mod:`pirate_bt.trace.sink_ring`: the ring of shared memory for ticks.
- :mod:`pirate_bt.trace.sink_messages`: the message kinds, their framing
  (:func:`frame`, :func:`unframe`) and the writer process's loop (:func:`serve`).
- this module: :class:`SinkProcess` (the recorder's end of the pipe and the ring)
  and the writer process's entry point (:func:`main`). It re-exports every name of
  the first two and the public names of the fourth.

A format writer of a package above this one can run in a writer process too
(:func:`register_process_writer`; MCAP does, :mod:`pirate_bt.interop.mcap_writer`):
its module must import nothing from ``pirate_bt`` outside the modules that need
only the standard library at import time. The writer process imports it by name,
behind the same stand-in packages, with the recording process's ``sys.path``
after its own standard library, so that the writer may import a third-party
package when it starts (``mcap``).
"""

from __future__ import annotations

import contextlib
import json
import marshal
import math
import os
import signal
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

if not __package__:  # run as the writer process's script
    # ``python -I -S sink.py``: pirate_bt is not on the path, and the package's
    # ``__init__`` modules (which import py_trees and more) must not run. Stand-in
    # packages let this file import its siblings, which need the standard
    # library only.
    import types

    for _name, _folder in (
        ("pirate_bt", Path(__file__).resolve().parent.parent),
        ("pirate_bt.trace", Path(__file__).resolve().parent),
    ):
        _package = types.ModuleType(_name)
        _package.__path__ = [str(_folder)]
        sys.modules[_name] = _package

from pirate_bt.trace.sink_encode import DECIMALS as DECIMALS
from pirate_bt.trace.sink_encode import SINGLES as SINGLES
from pirate_bt.trace.sink_encode import VIEWS as VIEWS
from pirate_bt.trace.sink_encode import (
    CounterChanges,
    FieldChanges,
    StateDiff,
    TickEncoder,
    encode_value,
    layout_names,
    nonfinite_text,
    round_value,
    rounded_json,
)
from pirate_bt.trace.sink_encode import encode_json as encode_json
from pirate_bt.trace.sink_encode import encode_str as encode_str
from pirate_bt.trace.sink_encode import value_json as value_json
from pirate_bt.trace.sink_formats import (
    WRITER_CLASSES,
    GzipJsonLinesWriter,
    JsonLinesWriter,
    TraceFormatWriter,
    claim,
    forget_in_forks,
    let_go_in_forks,
    load_writer,
    register_process_writer,
    to_null,
    writer_spec,
)
from pirate_bt.trace.sink_messages import _LENGTH, _MARSHAL_VERSION, _PIPE_BYTES, _POLL_S
from pirate_bt.trace.sink_messages import BELL as BELL
from pirate_bt.trace.sink_messages import END as END
from pirate_bt.trace.sink_messages import LINE as LINE
from pirate_bt.trace.sink_messages import SETUP as SETUP
from pirate_bt.trace.sink_messages import TICK as TICK
from pirate_bt.trace.sink_messages import _messages as _messages
from pirate_bt.trace.sink_messages import frame as frame
from pirate_bt.trace.sink_messages import read_messages as read_messages
from pirate_bt.trace.sink_messages import serve as serve
from pirate_bt.trace.sink_messages import unframe as unframe
from pirate_bt.trace.sink_ring import BELL_S, PAUSE_S, Ring

__all__ = [
    "BELL",
    "END",
    "LINE",
    "SETUP",
    "TICK",
    "WRITER_CLASSES",
    "CounterChanges",
    "FieldChanges",
    "GzipJsonLinesWriter",
    "JsonLinesWriter",
    "SinkError",
    "SinkProcess",
    "StateDiff",
    "TickEncoder",
    "TraceFormatWriter",
    "encode_value",
    "frame",
    "layout_names",
    "nonfinite_text",
    "read_messages",
    "register_process_writer",
    "round_value",
    "rounded_json",
    "unframe",
]


# --- the writer process ------------------------------------------------------------

_pack_length = _LENGTH.pack
_dumps = marshal.dumps
_write = os.write
_perf_counter = time.perf_counter
_NICE = 10
"""How much nicer than the run the writer process is."""


class SinkError(RuntimeError):
    """The writer process failed or could not be reached."""


class SinkProcess:
    """A writer process fed with messages over a pipe and a ring (see the module docstring).

    The trace file is opened (created, taken for this run, truncated: see
    :func:`~pirate_bt.trace.sink_formats.claim`) here, so an unwritable path, or one
    another run is writing, fails at once in the caller's process; the writer process
    inherits it.

    Args:
        path: The trace file.
        writer: Name of the format writer class (a key of :data:`WRITER_CLASSES`).
        sync: fsync after every record.

    Raises:
        TraceBusyError: another writer holds the file (it is left as it was).
        OSError: the file cannot be opened.
        SinkError: the process cannot start.
    """

    def __init__(self, path: str | Path, writer: str, sync: bool = False) -> None:
        if writer not in WRITER_CLASSES:
            raise ValueError(f"no writer class {writer!r} for a writer process")
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        import subprocess  # here, not at the top: the writer process itself never needs it

        cls = WRITER_CLASSES[writer]
        cls.preflight(self.path)  # what is missing is said here, not by a dead process
        # Taken (locked) before it is emptied: a file another run is writing is refused
        # and stays whole; the writer process inherits the descriptor and the lock.
        fd = claim(self.path, truncate=True)
        created = Ring.create()
        self._ring: Ring | None = created[0] if created is not None else None
        ring_fd = created[1] if created is not None else -1
        try:
            if not Path(__file__).is_file() or not sys.executable:
                raise SinkError(f"{self.path}: no interpreter or script for a trace writer process")
            spec = writer_spec(cls)
            self._proc = subprocess.Popen(
                [
                    sys.executable,
                    "-I",  # no user site, no environment, no script folder on the path
                    "-S",  # no site-packages: this file needs the standard library only
                    __file__,
                    str(fd),
                    spec,
                    "1" if sync else "0",
                    str(self.path),  # names the process in ps
                    f"{ring_fd}:{self._ring.capacity}" if self._ring is not None else "-",
                    *([json.dumps(sys.path)] if ":" in spec else []),
                ],
                stdin=subprocess.PIPE,
                stdout=subprocess.DEVNULL,
                stderr=subprocess.PIPE,
                pass_fds=(fd,) if ring_fd < 0 else (fd, ring_fd),
                start_new_session=True,  # a signal to the run's process group spares it
            )
        except (OSError, ValueError) as exc:  # ValueError: no pass_fds (not POSIX)
            if self._ring is not None:
                self._ring.close()
            raise SinkError(f"{self.path}: cannot start a trace writer process: {exc}") from exc
        finally:
            os.close(fd)
            if ring_fd >= 0:
                os.close(ring_fd)  # mapped: the descriptor is not needed any more
        _make_nicer(self._proc.pid)  # from its first instruction, not once it has started
        assert self._proc.stdin is not None
        self._fd = self._proc.stdin.fileno()
        try:  # a deep pipe: the writer process drains it in batches, not once per tick
            import fcntl

            fcntl.fcntl(self._fd, getattr(fcntl, "F_SETPIPE_SZ", 1031), _PIPE_BYTES)
        except (ImportError, OSError):
            pass
        self._closed = False
        self._reason: str | None = None
        self._stderr = b""
        # The ring's positions as this end knows them (see sink_ring): written, rung, and
        # read by the writer process (refreshed only when the ring looks full); a tick
        # message longer than an eighth of the ring goes through the pipe.
        self._head = self._belled = self._tail = 0
        self._bell_s = self._put_s = -math.inf
        self._capacity = self._ring.capacity if self._ring is not None else 0
        self._largest = self._capacity // 8
        let_go_in_forks(self)

    def _forked(self) -> None:
        """In a process forked from the run's: let go of the writer process (see
        :func:`~pirate_bt.trace.sink_formats.let_go_in_forks`). Its pipe kept the writer
        process waiting, and with it the trace's lock, for as long as this copy lived;
        what this copy sends goes nowhere, the ring is left to the run, and ``close``
        neither waits for the writer process nor stops it."""
        if self._closed:  # closed in the run's process: its descriptor's number may be
            return  # another's now (a process pool's pipe, which /dev/null hung)
        stderr = self._proc.stderr
        to_null(self._fd, *([stderr.fileno()] if stderr is not None and not stderr.closed else []))
        self._ring = None
        self._largest = 0
        self._closed = True

    @property
    def pid(self) -> int:
        """The writer process's id."""
        return self._proc.pid

    def send(self, message: tuple[Any, ...]) -> None:
        """Hand one message to the writer process.

        On return it is in memory the kernel keeps for the writer process: a tick in
        the ring (where there is one), anything else in the pipe.

        Raises:
            ValueError: the message holds a value ``marshal`` cannot carry.
            SinkError: the writer process has gone (for a tick put in the ring: noticed
                at the next bell, see :mod:`~pirate_bt.trace.sink_ring`).
        """
        # frame(), inlined: this runs once per tick.
        data = _dumps(message, _MARSHAL_VERSION)
        data = _pack_length(len(data)) + data
        ring = self._ring
        if ring is not None and message[0] == TICK and len(data) <= self._largest:
            now = _perf_counter()
            last_s, self._put_s = self._put_s, now
            if now - last_s <= PAUSE_S:
                # Ticks coming fast: copied into the ring, a system call only to ring a
                # bell now and then (see sink_ring).
                end = self._head + len(data)
                if end - self._tail > self._capacity:
                    self._make_room(end)
                self._head = ring.put(self._head, data)
                if now - self._bell_s > BELL_S:
                    self._bell(now)
                return
            # A tick after a pause (every tick of a paced run) goes through the pipe: one
            # write, as a bell would cost, and nothing in the ring to read later.
        if self._head != self._belled:
            self._bell(_perf_counter())  # what the ring holds comes first
        self._write(data)

    def send_tick(self, message: tuple[Any, ...]) -> None:
        """:meth:`send` for a ``TICK`` message (the recorder's, once per tick): the same.

        Raises:
            ValueError: the message holds a value ``marshal`` cannot carry.
            SinkError: the writer process has gone (see :meth:`send`).
        """
        payload = _dumps(message, _MARSHAL_VERSION)
        size = len(payload) + 4  # framed
        if size <= self._largest:  # (0 without a ring)
            now = _perf_counter()
            last_s = self._put_s
            self._put_s = now
            if now - last_s <= PAUSE_S:  # as in send(): into the ring
                head = self._head
                if head + size - self._tail > self._capacity:
                    self._make_room(head + size)
                self._head = self._ring.put_payload(head, payload)  # type: ignore[union-attr]
                if now - self._bell_s > BELL_S:
                    self._bell(now)
                return
        if self._head != self._belled:
            self._bell(_perf_counter())
        self._write(_pack_length(size - 4) + payload)

    def _bell(self, now: float) -> None:
        """Tell the writer process how far the ring is written (and learn if it is alive)."""
        self._belled, self._bell_s = self._head, now
        self._write(frame((BELL, self._head)))

    def _make_room(self, end: int) -> None:
        """Wait until the writer process has read the ring far enough to write up to ``end``."""
        assert self._ring is not None
        if self._head != self._belled:
            self._bell(_perf_counter())  # it reads only what was rung
        while True:
            self._tail = self._ring.tail()
            if end - self._tail <= self._capacity:
                return
            if self._proc.poll() is not None:
                raise SinkError(self._failure())
            time.sleep(_POLL_S / 4)

    def _write(self, data: bytes) -> None:
        try:
            written = _write(self._fd, data)
            while written < len(data):
                written += _write(self._fd, data[written:])
        except BrokenPipeError:
            raise SinkError(self._failure()) from None

    def close(self, timeout_s: float = 60.0) -> None:
        """Close the pipe and wait until the writer process has written everything.

        Raises:
            SinkError: the writer process failed (its message is included), or did
                not finish within ``timeout_s``.
        """
        if self._closed:
            return
        self._closed = True
        forget_in_forks(self)
        assert self._proc.stdin is not None
        # No last bell: at the end of its input the writer process reads the ring to the end.
        with contextlib.suppress(BrokenPipeError):
            self._proc.stdin.close()
        try:
            # Its standard error closes when it exits: wait for that end of file, not with
            # Popen.wait(timeout), which polls with growing sleeps and overshoots by ms.
            if not self._drain_stderr(timeout_s):
                self._proc.kill()
                self._proc.wait()
                raise SinkError(f"{self.path}: the trace writer did not finish in {timeout_s:g} s")
            if self._proc.wait() != 0:
                raise SinkError(self._failure())
        finally:
            if self._ring is not None:
                self._ring.close()

    def _drain_stderr(self, timeout_s: float) -> bool:
        """Read the writer's standard error to its end; ``False`` if that took too long."""
        import select

        stream = self._proc.stderr
        if stream is None or stream.closed:
            return True
        fd = stream.fileno()
        deadline = time.monotonic() + timeout_s
        while True:
            left = deadline - time.monotonic()
            if left <= 0 or not select.select([fd], [], [], left)[0]:
                return False
            chunk = os.read(fd, 65536)
            if not chunk:
                stream.close()
                return True
            self._stderr += chunk

    def _failure(self) -> str:
        if self._reason is None:
            self._drain_stderr(5.0)
            code = self._proc.wait(5)
            text = self._stderr.decode("utf-8", "replace").strip()
            detail = text.splitlines()[-1] if text else ""
            because = f": {detail}" if detail else ""
            self._reason = f"{self.path}: the trace writer failed (exit {code}){because}"
        return self._reason


def _make_nicer(pid: int, than: int = 0) -> None:
    """Make the writer process ``pid`` :data:`_NICE` nicer than the run (process ``than``).

    The run's ticks come first: on a busy machine the writer process yields the CPU to
    the run and catches up in the gaps (the ring holds thousands of ticks meanwhile).
    It has a session of its own, which Linux schedules as a group of its own
    (autogroup): the group is made nicer too, or the nice value would only count
    inside it. The recorder does this as soon as the process exists, so that its
    start (about 20 ms of the CPU: the interpreter, its imports) already yields to
    the run; the writer process does it again, in case that failed. Best effort
    (Linux lets a user do the group's only once per 100 ms, machine-wide).
    """
    with contextlib.suppress(OSError, AttributeError):  # AttributeError: not POSIX
        nice = min(19, os.getpriority(os.PRIO_PROCESS, than) + _NICE)
        if os.getpriority(os.PRIO_PROCESS, pid) < nice:
            os.setpriority(os.PRIO_PROCESS, pid, nice)
    with contextlib.suppress(OSError), open(f"/proc/{pid}/autogroup", "w") as group:
        group.write(str(_NICE))


def main(argv: Sequence[str]) -> int:
    """The writer process: ``sink.py FD WRITER SYNC [PATH [RING [SYS_PATH]]]``; messages on stdin.

    ``WRITER`` is a name of :data:`WRITER_CLASSES` or ``module:class`` (then
    ``SYS_PATH``, the recording process's ``sys.path`` as JSON, is searched after
    the standard library). ``RING`` is ``FD:CAPACITY`` of the ring's shared memory,
    or ``-`` for none.
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the run's Ctrl-C is for the run
    _make_nicer(os.getpid(), os.getppid())  # done by the recorder already, as a rule
    fd, writer, sync = int(argv[1]), argv[2], argv[3] == "1"
    path = argv[4] if len(argv) > 4 else f"fd {fd}"
    ring: Ring | None = None
    try:
        if len(argv) > 5 and argv[5] != "-":
            ring_fd, capacity = map(int, argv[5].split(":"))
            ring = Ring(ring_fd, capacity)
            os.close(ring_fd)
        paths = json.loads(argv[6]) if len(argv) > 6 else []
        out = load_writer(writer, paths)(path, sync=sync, fd=fd)
    except Exception as exc:
        print(f"trace writer: cannot open {writer}: {type(exc).__name__}: {exc}", file=sys.stderr)
        return 1
    try:
        if not serve(sys.stdin.fileno(), out, ring):
            out.cut_off()
    except Exception as exc:  # reported to the recorder through the exit code and stderr
        print(f"trace writer: {type(exc).__name__}: {exc}", file=sys.stderr)
        return 1
    finally:
        out.close()
    return 0


if __name__ == "__main__":
    status = main(sys.argv)
    sys.stderr.flush()
    os._exit(status)  # the file is closed: no interpreter teardown to wait for
