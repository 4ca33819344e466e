"""The half of the trace writer that needs only the standard library.

:class:`~pirate_bt.trace.TraceRecorder` is split in two, so that the tick pays
for as little as possible:

- **Capture** (``writer.py``, in the tick's thread): read every node's status and
  feedback message, the blackboard, and the raw values of the robot state, link
  health and simulator counters; keep only what moved; hand that over as one
  small tuple of plain values (a *message*, below).
- **Encode and write** (this module): compare the values with what was last
  recorded, round them, assemble the tick record's JSON text and write it as one
  line. :class:`TickEncoder` does the first part and the format writers
  (:class:`JsonLinesWriter`, :class:`GzipJsonLinesWriter`) the second.

By default the second half runs in a **writer process** (:class:`SinkProcess`,
this file run as a script): the recorder ``marshal``\\s each message onto a pipe
and the writer process encodes, compresses and writes while the robot's process
goes on with the next tick. Crash safety is kept: a message is in the kernel's
pipe buffer once ``os.write`` returns, and the writer process outlives the
recorder's process, so a run killed with SIGKILL still has every tick it handed
over written out (the writer sees the pipe close, writes what is left and exits).
The writer process runs in its own session, so a signal to the run's process
group does not stop it either. With ``background=False``, or for a format
writer this module does not know, the same :class:`TickEncoder` runs in-process.

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
``(TICK, n, t_s, status, feedback, bb, state_keys, state_raw, commands, link, sim, events)``
    One tick: ``t_s`` is the seconds since the header (not yet rounded),
    ``status`` a list of ``(index, code)``, ``feedback`` a list of
    ``(index, message)``, ``bb`` and ``events`` the JSON members already
    encoded (``,"bb":{...}``), ``state_keys``/``state_raw`` the state's layout
    (``None`` when unchanged) and raw values (``None`` when not given or
    unchanged), ``commands`` a list of JSON texts, ``link`` the raw
    link-health tuple and
    ``sim`` the counters (``None`` when unchanged or not given).

On the pipe each message is a 4-byte little-endian length and its ``marshal``
bytes. This module imports nothing from ``pirate_bt`` and nothing outside the
standard library, so the writer process starts in a few milliseconds.
"""

from __future__ import annotations

import contextlib
import gzip
import json
import marshal
import math
import os
import signal
import struct
import sys
import time
import zlib
from collections.abc import Iterable, Mapping, Sequence
from enum import Enum
from itertools import compress, repeat
from operator import is_not, itemgetter, ne
from pathlib import Path
from typing import IO, TYPE_CHECKING, Any, ClassVar, cast

if TYPE_CHECKING:
    pass

__all__ = [
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
    "layout_names",
    "nonfinite_text",
    "round_value",
    "rounded_json",
]

SETUP, LINE, TICK, END = 0, 1, 2, 3

# Floats in state, link and counter values are rounded to this many decimals:
# 1 µrad, 1 µm/s, 1 µN are far below any sensor's resolution, and rounding
# keeps noise in the last bits from counting as a change.
DECIMALS = 6

_INF = float("inf")
_MISSING: Any = object()
_first = itemgetter(0)
_second = itemgetter(1)
_concat = str.__add__

# One encoder built once: json.dumps with keyword arguments builds a new JSONEncoder
# on every call. Records hold fresh plain data (no cycles), so the check is skipped.
encode_json = json.JSONEncoder(
    separators=(",", ":"), ensure_ascii=False, allow_nan=False, check_circular=False
).encode
"""Any JSON value as compact text, non-ASCII kept, non-finite numbers refused."""
encode_str = json.encoder.encode_basestring
"""A ``str`` as JSON text, non-ASCII kept (what :data:`encode_json` does, in C)."""

_NUMBERS_MAX = 1 << 16
"""Most raw floats a :class:`StateDiff` keeps the rounded value and text of."""


# --- values ------------------------------------------------------------------------


def nonfinite_text(value: float) -> str:
    """How the trace spells a number strict JSON has no spelling for: ``nan``, ``inf``, ``-inf``."""
    return "nan" if math.isnan(value) else ("inf" if value > 0 else "-inf")


def round_value(value: float) -> float | str:
    """A float rounded to 6 decimals; ``nan``, ``inf``, ``-inf`` as those strings."""
    return round(value, DECIMALS) if math.isfinite(value) else nonfinite_text(value)


def encode_value(value: Any) -> Any:
    """A state, health or counter value as JSON data: floats rounded (non-finite as strings)."""
    kind = type(value)
    if kind is float:
        return round(value, DECIMALS) if -_INF < value < _INF else round_value(value)
    if kind is int or kind is bool or kind is str or value is None:
        return value
    if isinstance(value, Enum):
        return encode_value(value.value)
    if isinstance(value, bool | int | str):
        return value
    if isinstance(value, float):  # a float subclass, such as numpy's float64
        return round_value(float(value))
    if isinstance(value, Mapping):
        return {str(k): encode_value(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [encode_value(v) for v in value]
    return repr(value)


def rounded_json(value: Any) -> tuple[Any, str]:
    """``value`` as :func:`encode_value` gives it, and that as JSON text."""
    encoded = encode_value(value)
    return encoded, repr(encoded) if type(encoded) is float else encode_json(encoded)


def value_json(value: Any) -> str:
    """A feedback message (or anything else) as JSON text."""
    return encode_str(value) if type(value) is str else encode_json(encode_value(value))


# --- state -------------------------------------------------------------------------

VIEWS = ("joint_angle_rad", "clamp_force_n", "imu_rad", "drive_velocity_mps", "motor_current_a")
"""The role-based views of a state snapshot, in the order of a layout."""
SINGLES = ("rotation_rad", "camera_tilt_rad", "camera_pan_rad", "front_tilt_rad")
"""The single values of a state snapshot, after the views."""


def layout_names(keys: Sequence[str | None], readings: bool) -> list[str]:
    """Flat state names (``joint_angle_rad.bend_1``...) for a state layout.

    A layout is the key of every view in :data:`VIEWS` order, each view ended by
    ``None``, then (with ``readings``) the channel names; the raw values that go
    with it are the views' values, the :data:`SINGLES`, then the channels'.
    """
    names: list[str] = []
    views = iter(VIEWS)
    view = next(views)
    for index, key in enumerate(keys):
        if key is None:
            view = next(views, "")
            if not view:  # past the last view: the readings, if any
                names += SINGLES
                if readings:
                    names += [f"readings.{name}" for name in keys[index + 1 :]]
                break
        else:
            names.append(f"{view}.{key}")
    return names


class StateDiff:
    """The flat state values that changed since they were last recorded.

    Fed a layout (when it changes) and a tuple of raw values, it returns the
    values that differ from the last recorded ones after rounding: a raw change
    that rounds to the recorded value is noise, not a change, and a value that
    stops being reported (``None``) is not a change either. An unchanged tuple
    costs one tuple comparison; otherwise only the values that moved are looked
    at, in C loops (``map``, ``compress``), with their rounded value and JSON
    text taken from a cache, since readings are quantised and values recur.
    """

    def __init__(self, readings: bool = False) -> None:
        self.readings = readings
        self.values: dict[str, Any] = {}
        """Flat name -> last recorded (rounded) value."""
        self.names: tuple[str, ...] = ()
        self._members: tuple[str, ...] = ()
        self._raw: tuple[Any, ...] = ()
        self._last: list[Any] = []
        self._numbers: dict[float, tuple[Any, str]] = {}

    def set_layout(self, keys: Sequence[str | None]) -> None:
        """A new layout (first snapshot, or a sensor appeared): every value is looked at."""
        self.names = tuple(layout_names(keys, self.readings))
        self._members = tuple([encode_str(name) + ":" for name in self.names])
        self._last = [self.values.get(name, _MISSING) for name in self.names]
        self._raw = ()

    def diff(self, raw: tuple[Any, ...]) -> tuple[list[int], list[Any], list[str]]:
        """Record ``raw``; the indices, rounded values and JSON texts of what changed."""
        previous = self._raw
        if raw == previous:
            return [], [], []
        self._raw = raw
        if len(previous) != len(raw):
            previous = (_MISSING,) * len(raw)
        indices = list(compress(range(len(raw)), map(ne, raw, previous)))
        moved = list(map(raw.__getitem__, indices))
        hits: list[tuple[Any, str] | None] = list(map(self._numbers.get, moved))
        if None in hits:
            hits = list(map(self._number, moved))
            if None in hits:  # a value no longer reported (None) is not a change
                present = list(map(is_not, hits, repeat(None)))
                indices = list(compress(indices, present))
                hits = list(compress(hits, present))
        found = cast(list[tuple[Any, str]], hits)
        last = self._last
        rounded = list(map(_first, found))
        fresh = list(map(ne, rounded, map(last.__getitem__, indices)))
        if False in fresh:
            indices = list(compress(indices, fresh))
            rounded = list(compress(rounded, fresh))
            found = list(compress(found, fresh))
        for index, value in zip(indices, rounded, strict=True):
            last[index] = value
        self.values.update(zip(map(self.names.__getitem__, indices), rounded, strict=True))
        return indices, rounded, list(map(_second, found))

    def diff_json(self, raw: tuple[Any, ...]) -> str:
        """:meth:`diff` as the members of a JSON object (``"name":value,...``), or ``""``."""
        indices, _, texts = self.diff(raw)
        return ",".join(map(_concat, map(self._members.__getitem__, indices), texts))

    def full_json(self, raw: tuple[Any, ...]) -> str:
        """Every reported value (the ``full_state`` option), recording them as well."""
        self.diff(raw)
        parts = [
            self._members[index] + rounded_json(value)[1]
            for index, value in enumerate(raw)
            if value is not None
        ]
        return ",".join(parts)

    def _number(self, value: Any) -> tuple[Any, str] | None:
        if value is None:
            return None
        # Only finite, non-zero floats are cached: 0.0 == -0.0 would share one spelling,
        # nan never equals itself, and an int would take the spelling of an equal float.
        if type(value) is float and -_INF < value < _INF and value:
            numbers = self._numbers
            if len(numbers) >= _NUMBERS_MAX:
                numbers.clear()
            rounded = round(value, DECIMALS)
            hit = numbers[value] = (rounded, repr(rounded))
            return hit
        return rounded_json(value)


class FieldChanges:
    """The values of a fixed list of named fields that changed since the last call.

    For link health, which the trace reads every tick but which changes rarely:
    the raw values arrive as one tuple, so an unchanged reading costs one tuple
    comparison, and only fields whose raw value differs are encoded (floats
    rounded) and compared with what was recorded.

    Args:
        names: The field names, in the order of the tuples given to :meth:`changes`.
    """

    def __init__(self, names: Sequence[str]) -> None:
        self.names = tuple(names)
        self.values: dict[str, Any] = {}
        """Field name -> last recorded (encoded) value."""
        self._raw: tuple[Any, ...] = (_MISSING,) * len(self.names)

    def changes(self, raw: tuple[Any, ...]) -> dict[str, Any]:
        """Record ``raw`` (one value per name) and return the encoded values that changed."""
        previous = self._raw
        if raw == previous:
            return {}
        self._raw = raw
        moved = compress(zip(self.names, raw, strict=True), map(ne, raw, previous))
        return _record(self.values, moved)


class CounterChanges:
    """Simulator counters (name -> number) that changed; names may come and go."""

    def __init__(self) -> None:
        self.values: dict[str, Any] = {}
        """Counter name -> last recorded (encoded) value."""
        self._raw: dict[Any, Any] = {}

    def changes(self, sim: Mapping[Any, Any]) -> dict[str, Any]:
        """Record ``sim`` and return the encoded values that changed (possibly empty)."""
        raw = self._raw
        if sim == raw:
            return {}
        keys = list(compress(list(sim), map(ne, sim.values(), map(raw.get, sim, repeat(_MISSING)))))
        raw.update(zip(keys, map(sim.__getitem__, keys), strict=True))
        names = [key if type(key) is str else str(key) for key in keys]
        return _record(self.values, zip(names, map(sim.__getitem__, keys), strict=True))


def _record(values: dict[str, Any], moved: Iterable[tuple[str, Any]]) -> dict[str, Any]:
    """Encode the raw values that moved; keep and return those that differ from ``values``."""
    changed: dict[str, Any] = {}
    for name, value in moved:
        encoded = encode_value(value)
        if values.get(name, _MISSING) != encoded:
            values[name] = encoded
            changed[name] = encoded
    return changed


# --- tick records ------------------------------------------------------------------


class TickEncoder:
    """Turns tick messages into tick records' JSON text (``None``: nothing to write).

    Args:
        node_ids: Path ids of the tree's nodes, depth first.
        link_fields: Names of the fields of the link-health tuples
            (``pirate_bt.trace.records.LINK_FIELDS``).
        every_tick: Give a line for every tick, even one where nothing changed.
        full_state: Give every state value in every tick that has a state.
        readings: The state layouts include the raw channels.
    """

    def __init__(
        self,
        node_ids: Sequence[str],
        *,
        link_fields: Sequence[str],
        every_tick: bool = False,
        full_state: bool = False,
        readings: bool = False,
    ) -> None:
        self.every_tick = every_tick
        self.full_state = full_state
        # Encoded once: each node's '"<id>":' member name, and its status members.
        self._members = [encode_str(node_id) + ":" for node_id in node_ids]
        self._status = [{code: f'{member}"{code}"' for code in "SFRI"} for member in self._members]
        self.state = StateDiff(readings=readings)
        self._link = FieldChanges(link_fields)
        self._sim = CounterChanges()

    def encode(self, message: Sequence[Any]) -> str | None:
        """The line for one ``TICK`` message, ``\\n``-terminated, or ``None``."""
        (_, n, t_s, status, feedback, bb, keys, raw, commands, link, sim, events) = message
        parts: list[str] = []
        if status:
            tables = self._status
            members = [tables[index][code] for index, code in status]
            parts.append(',"status":{' + ",".join(members) + "}")
        if feedback:
            names = self._members
            members = [names[index] + value_json(text) for index, text in feedback]
            parts.append(',"feedback":{' + ",".join(members) + "}")
        if bb:
            parts.append(bb)
        if keys is not None:
            self.state.set_layout(keys)
        if raw is not None:
            if self.full_state:
                parts.append(',"state":{' + self.state.full_json(raw) + '},"full":true')
            else:
                members_text = self.state.diff_json(raw)
                if members_text:
                    parts.append(',"state":{' + members_text + "}")
        if commands:
            parts.append(',"commands":[' + ",".join(commands) + "]")
        if link is not None:
            changed = self._link.changes(tuple(link))
            if changed:
                parts.append(',"link":' + encode_json(changed))
        if sim is not None:
            changed = self._sim.changes(sim)
            if changed:
                parts.append(',"sim":' + encode_json(changed))
        if events:
            parts.append(events)
        if not parts and not self.every_tick:
            return None
        t_s = round(t_s, DECIMALS)
        time_text = repr(t_s) if type(t_s) is float and -_INF < t_s < _INF else encode_json(t_s)
        return f'{{"type":"tick","n":{n},"t_s":{time_text}{"".join(parts)}}}\n'


# --- format writers ----------------------------------------------------------------


class TraceFormatWriter:
    """Writes trace records to a file in one format; subclasses implement ``_open``.

    Args:
        path: Where to write (created or truncated).
        sync: Also ``fsync`` after every record, for power loss (slower).
        fd: An open file descriptor for ``path`` to write to instead of opening it.
    """

    suffixes: ClassVar[tuple[str, ...]] = ()

    def __init__(self, path: str | Path, sync: bool = False, fd: int | None = None) -> None:
        self.path = Path(path)
        self.sync = sync
        if fd is None:
            self.path.parent.mkdir(parents=True, exist_ok=True)
        self._file = self._open(fd)

    def _open(self, fd: int | None) -> IO[bytes]:
        raise NotImplementedError

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
        self._file.write(line.encode("utf-8"))
        self._flush()
        if self.sync:
            os.fsync(self._file.fileno())

    def close(self) -> None:
        """Flush and close the file (idempotent)."""
        if not self._file.closed:
            self._file.close()


class JsonLinesWriter(TraceFormatWriter):
    """Plain JSON Lines (``.jsonl``); each line goes to the kernel with one ``os.write``."""

    suffixes = (".jsonl", ".ndjson")

    def _open(self, fd: int | None) -> IO[bytes]:
        # Unbuffered: each record goes to the kernel in write(), nothing waits in Python.
        if fd is not None:
            return open(fd, "wb", buffering=0)
        return open(self.path, "wb", buffering=0)

    def write_line(self, line: str) -> None:
        """Write one line with one ``os.write`` (the kernel has it on return)."""
        data = line.encode("utf-8")
        fd = self._file.fileno()
        written = os.write(fd, data)
        while written < len(data):  # a regular file takes it all; a pipe or a full disk may not
            written += os.write(fd, data[written:])
        if self.sync:
            os.fsync(fd)


class GzipJsonLinesWriter(TraceFormatWriter):
    """Gzip-compressed JSON Lines (``.jsonl.gz``), sync-flushed per record.

    A sync flush ends each record on a byte boundary of the deflate stream, so a
    killed run still decompresses up to its last complete tick.
    """

    suffixes = (".jsonl.gz",)

    def _open(self, fd: int | None) -> IO[bytes]:
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


# --- the writer process ------------------------------------------------------------

_LENGTH = struct.Struct("<I")
_POLL_S = 0.002
"""How long the writer process sleeps after draining the pipe: it is not woken by every
tick's write, and it notices the end of a run within this time."""
_PIPE_BYTES = 1 << 20


class SinkError(RuntimeError):
    """The writer process failed or could not be reached."""


class SinkProcess:
    """A writer process fed with messages over a pipe (see the module docstring).

    The trace file is opened (created, truncated) here, so an unwritable path
    fails at once in the caller's process; the writer process inherits it.

    Args:
        path: The trace file.
        writer: Name of the format writer class (a key of :data:`WRITER_CLASSES`).
        sync: fsync after every record.

    Raises:
        OSError: the file cannot be opened.
        SinkError: the process cannot start.
    """

    def __init__(self, path: str | Path, writer: str, sync: bool = False) -> None:
        if writer not in WRITER_CLASSES:
            raise ValueError(f"no writer class {writer!r} for a writer process")
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        import subprocess  # here, not at the top: the writer process itself never needs it

        fd = os.open(self.path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o666)
        try:
            if not Path(__file__).is_file() or not sys.executable:
                raise SinkError(f"{self.path}: no interpreter or script for a trace writer process")
            self._proc = subprocess.Popen(
                [
                    sys.executable,
                    "-I",  # no user site, no environment, no script folder on the path
                    "-S",  # no site-packages: this file needs the standard library only
                    __file__,
                    str(fd),
                    writer,
                    "1" if sync else "0",
                    str(self.path),  # unused; names the process in ps
                ],
                stdin=subprocess.PIPE,
                stdout=subprocess.DEVNULL,
                stderr=subprocess.PIPE,
                pass_fds=(fd,),
                start_new_session=True,  # a signal to the run's process group spares it
            )
        except (OSError, ValueError) as exc:  # ValueError: no pass_fds (not POSIX)
            raise SinkError(f"{self.path}: cannot start a trace writer process: {exc}") from exc
        finally:
            os.close(fd)
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

    @property
    def pid(self) -> int:
        """The writer process's id."""
        return self._proc.pid

    def send(self, message: tuple[Any, ...]) -> None:
        """Hand one message to the writer process (on return it is in the kernel's hands).

        Raises:
            ValueError: the message holds a value ``marshal`` cannot carry.
            SinkError: the writer process has gone.
        """
        payload = marshal.dumps(message)
        data = _LENGTH.pack(len(payload)) + payload
        try:
            written = os.write(self._fd, data)
            while written < len(data):
                written += os.write(self._fd, data[written:])
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
        assert self._proc.stdin is not None
        with contextlib.suppress(BrokenPipeError):
            self._proc.stdin.close()
        # Its standard error closes when it exits: wait for that end of file, not with
        # Popen.wait(timeout), which polls with growing sleeps and overshoots by ms.
        if not self._drain_stderr(timeout_s):
            self._proc.kill()
            self._proc.wait()
            raise SinkError(f"{self.path}: the trace writer did not finish in {timeout_s:g} s")
        if self._proc.wait() != 0:
            raise SinkError(self._failure())

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


def _messages(fd: int) -> Any:
    """Messages read off ``fd`` until it closes; a cut-off last message is dropped."""
    buffer = b""
    while True:
        chunk = os.read(fd, _PIPE_BYTES)
        if not chunk:
            return
        buffer += chunk
        view = memoryview(buffer)
        start = 0
        while len(buffer) - start >= 4:
            (size,) = _LENGTH.unpack_from(view, start)
            end = start + 4 + size
            if end > len(buffer):
                break
            yield marshal.loads(view[start + 4 : end])
            start = end
        view.release()
        buffer = buffer[start:]
        time.sleep(_POLL_S)  # let messages gather: no wake-up of this process per tick


def serve(fd_in: int, out: TraceFormatWriter) -> None:
    """Write the records of the messages read off ``fd_in`` to ``out``, until it closes."""
    encoder: TickEncoder | None = None
    for message in _messages(fd_in):
        kind = message[0]
        if kind == TICK:
            assert encoder is not None, "a tick before the setup message"
            line = encoder.encode(message)
            if line is not None:
                out.write_line(line)
        elif kind == LINE:
            out.write_line(message[1])
        elif kind == END:
            out.write_line(message[1])
            return
        elif kind == SETUP:
            _, ids, every_tick, full_state, readings, link_fields = message
            encoder = TickEncoder(
                ids,
                every_tick=every_tick,
                full_state=full_state,
                readings=readings,
                link_fields=link_fields,
            )
        else:
            raise ValueError(f"unknown message kind {kind!r}")


def main(argv: Sequence[str]) -> int:
    """The writer process: ``sink.py FD WRITER SYNC [PATH]``; messages on standard input."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the run's Ctrl-C is for the run
    fd, writer, sync = int(argv[1]), argv[2], argv[3] == "1"
    path = argv[4] if len(argv) > 4 else f"fd {fd}"
    out = WRITER_CLASSES[writer](path, sync=sync, fd=fd)
    try:
        serve(sys.stdin.fileno(), out)
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
