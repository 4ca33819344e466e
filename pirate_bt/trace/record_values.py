"""What a trace's tick and end records must hold to be counted, shown and plotted.

The reader turned a tick's ``n`` with ``int`` and its ``t_s`` with ``float``, so a
record edited by hand or written by another tool read as something else: ``n``
``true`` became tick 1 and ``2.7`` tick 2 (then refused as *tick 2 does not follow
tick 2*, naming no real fault), and ``NaN`` or ``Infinity`` (which Python's
``json`` writes and reads though JSON has no such numbers) gave ``trace summary``
a duration of ``nan s`` and ``trace plot`` a window it blamed on options nobody
gave. An end record whose ``n`` was below the last tick's cut the run short in
the summary (``ticks 5`` of a run of 136) and in ``trace show``. A tick's
``events`` that held no objects ended ``trace summary`` with an internal error.
These checks say so, on the record's line, as every other bad record is refused.

A ``t_s`` that goes backwards is kept: it is the difference of the caller's
clock, which may be a wall clock that was set back.

A JSON escape of half a UTF-16 pair (``"\\ud800"``) is valid JSON but no
character; the writer escapes so a feedback message or name that holds one (text
decoded from bytes that were no UTF-8, say), and ``trace summary`` and ``show`` then
ended with an internal error printing it. :func:`readable_text` reads each as
U+FFFD for :func:`~pirate_bt.trace.reader.read_trace`, as a decoder reads bytes
that are no UTF-8.
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Mapping
from pathlib import Path
from typing import IO, Any, Final

from pirate_bt.errors import InputError, shown
from pirate_bt.trace.records import TRACE_VERSION

__all__ = [
    "end_values_problem",
    "opened_as_text",
    "order_problem",
    "readable_text",
    "stray_record",
    "tick_values_problem",
    "version_problem",
]

_HALF_PAIR_ESCAPE = re.compile(rb"\\u[dD][89abcdefABCDEF]")
_HALF_PAIR = re.compile("[\ud800-\udfff]")


def _whole(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _finite(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


def _shown(value: Any) -> str:
    return json.dumps(value)[:40]


def version_problem(version: Any) -> str | None:
    """What is wrong with a header's format ``version`` for this reader, or ``None``.

    A version above :data:`~pirate_bt.trace.records.TRACE_VERSION` is a layout this
    reader would misread (``trace export`` to ``.mcap`` and to a rosbag2 folder
    converted such a file as if it were version 1); one that is no whole number
    from 1 (``"1"``, ``1.0``, ``null``) was said to be "newer than this reader".
    """
    if _whole(version) and 1 <= version <= TRACE_VERSION:
        return None
    if _whole(version) and version > TRACE_VERSION:
        return (
            f"trace format version {version} is newer than this reader"
            f" ({TRACE_VERSION}); update pirate_bt"
        )
    return f"trace format version {_shown(version)} is no version (a whole number from 1)"


_OBJECTS: Final = ("status", "feedback", "bb", "state", "link", "sim")
"""The members of a tick record that map names to values."""


def tick_values_problem(record: Mapping[str, Any]) -> str | None:
    """What is wrong with a tick record's ``n``, ``t_s`` or ``events``, or ``None``.

    ``n`` is a whole number from 1 (the first tick is 1), ``t_s`` a finite number
    (both there), ``events`` a list of objects,
    ``bb_unset`` a list of text and ``status``, ``feedback``, ``bb``, ``state``,
    ``link`` and ``sim`` objects.
    """
    for name in ("n", "t_s"):  # said 'KeyError: 'n'' until the twentieth session
        if name not in record:
            return f"no {name}: a tick record holds its number n and its time t_s"
    n, t_s = record["n"], record["t_s"]
    if not _whole(n) or n < 1:
        return f"n is the tick's number, a whole number from 1, not {_shown(n)}"
    if not _finite(t_s):
        return f"t_s is the tick's time, a finite number of seconds, not {_shown(t_s)}"
    events = record.get("events", [])
    if not isinstance(events, list) or not all(isinstance(e, dict) for e in events):
        return f"events is a list of objects, not {_shown(events)}"
    unset = record.get("bb_unset", [])  # text unset one key per character
    if not isinstance(unset, list) or not all(isinstance(k, str) for k in unset):
        return f"bb_unset is a list of blackboard keys, not {_shown(unset)}"
    for member in _OBJECTS:  # a list of pairs read as an object
        if not isinstance(record.get(member, {}), dict):
            return f"{member} is an object, not {_shown(record[member])}"
    return _members_problem(record)


_NONFINITE: Final = ("nan", "inf", "-inf")
"""How a trace spells the numbers strict JSON cannot (``sink_encode.nonfinite_text``)."""


def _members_problem(record: Mapping[str, Any]) -> str | None:
    """What is wrong with a tick's state values (numbers, or ``nan``, ``inf``, ``-inf``:
    ``"x"`` made ``robot_state_at`` raise *could not convert string to float*), its
    feedback (text) or ``full`` (``true`` or ``false``), or ``None``."""
    for key, value in record.get("state", {}).items():
        if type(value) is not float and (
            not isinstance(value, int | float | str)
            or isinstance(value, bool)
            or (isinstance(value, str) and value not in _NONFINITE)
        ):
            return f"state: {key}: {_shown(value)} is no number"
    for node, text in record.get("feedback", {}).items():
        if not isinstance(text, str):
            return f"feedback: node {node}: {_shown(text)} is no text"
    if not isinstance(record.get("full", False), bool):
        return f"full is true or false, not {_shown(record['full'])}"
    return None


def stray_record(kind: str) -> str:
    """What is wrong with a record of ``kind`` where no such record may be: after the
    header, a header is a second run's (``cat a.jsonl b.jsonl``); it was "unknown"."""
    if kind == "header":
        return "a second header record: a trace holds one run (two files joined?)"
    # shown() quotes it once (it said "'note'"); a control character is escaped
    return f"unknown record type {shown(kind, 40)}: a trace holds a header, ticks and an end"


def order_problem(n: int, last_tick: int, end_line: int) -> str | None:
    """What is wrong with tick ``n`` coming after tick ``last_tick`` (0 before the
    first) and, when ``end_line`` is not 0, after the end record on that line."""
    if end_line:
        return "a tick after the end record"
    if last_tick and n <= last_tick:
        return f"tick {n} does not follow tick {last_tick}"
    return None


def end_values_problem(record: Mapping[str, Any], last_tick: int, first_end: int = 0) -> str | None:
    """What is wrong with an end record's ``t_s``, ``error`` (an object) or
    ``commands`` (a list of objects, as a tick's), or its ``n`` given the last tick
    record's number ``last_tick`` (0 without one), or ``None``. ``first_end`` is
    the line of an end record before this one (a second one replaced the first).
    """
    if first_end:
        return f"a second end record (the first is on line {first_end}): two files joined?"
    t_s, n = record.get("t_s", 0.0), record.get("n", 0)
    if not _finite(t_s):
        return (
            f"bad end record: t_s is the run's time, a finite number of seconds, not {_shown(t_s)}"
        )
    error, commands = record.get("error", {}), record.get("commands", [])
    if not isinstance(error, dict):  # ended trace summary with an internal error
        return f"bad end record: error is an object (node, exception), not {_shown(error)}"
    if not isinstance(commands, list) or not all(isinstance(c, dict) for c in commands):
        return f"bad end record: commands is a list of objects, not {_shown(commands)}"
    if _whole(n) and n < last_tick:
        last = f"n {n}, the run's last tick, is before tick {last_tick}"
        return f"bad end record: {last}, which it records"
    return None


_BINARY: Final = {
    b"\x1f\x8b": ("a gzip-compressed", ".jsonl.gz"),
    b"\x89MCAP": ("an MCAP", ".mcap"),
}
"""The first bytes of the other formats a trace is written in, and their suffix."""


def opened_as_text(path: Path) -> IO[bytes]:
    """``path`` opened to be read as JSON Lines, unless it starts as another format
    of trace does: a gzip-compressed or MCAP trace renamed ``.jsonl`` was "not a trace
    record: 'utf-8' codec can't decode byte 0x8b", or its first line "cut off".

    Raises:
        InputError: it is gzip or MCAP, naming the suffix to give it.
        OSError: it cannot be opened.
    """
    stream = open(path, "rb")  # noqa: SIM115 - returned open
    start = stream.peek(5)[:5]
    for magic, (kind, suffix) in _BINARY.items():
        if start.startswith(magic):
            stream.close()
            raise InputError(f"{path}: {kind} trace, not JSON Lines: name it {path.stem}{suffix}")
    return stream


def refuse_not_gzip(path: Path) -> None:
    """Refuse a ``.jsonl.gz`` trace that starts as JSON Lines or MCAP does, naming the
    suffix to give it: it was "not readable as gzip after 0 lines: Not a gzipped file
    (b'{"')", where a gzip trace renamed ``.jsonl`` is told its name.

    Raises:
        InputError: it is JSON Lines or MCAP.
        OSError: it cannot be opened.
    """
    with open(path, "rb") as stream:
        start = stream.read(5)
    base = path.name[: -len(".jsonl.gz")] if path.name.lower().endswith(".jsonl.gz") else path.stem
    if start.startswith(b"\x89MCAP"):
        raise InputError(f"{path}: an MCAP trace, not gzip-compressed: name it {base}.mcap")
    if start.lstrip(b"\xef\xbb\xbf \t\r\n").startswith(b"{"):
        raise InputError(f"{path}: a JSON Lines trace, not gzip-compressed: name it {base}.jsonl")


def readable_text(record: Any, line: bytes, mend: bool = True) -> Any:
    """``record`` (decoded from ``line``) with every lone surrogate in its text,
    keys too, made U+FFFD; ``record`` itself unless ``mend`` and ``line`` escapes one.

    :func:`~pirate_bt.trace.reader.read_trace` mends (a :class:`Trace` is shown and
    printed); the exports read records as written, so that a name converts as it is.
    """
    if not mend or _HALF_PAIR_ESCAPE.search(line) is None:
        return record
    return _mended(record)


def _mended(value: Any) -> Any:
    if isinstance(value, str):
        return _HALF_PAIR.sub("\ufffd", value)
    if isinstance(value, list):
        return [_mended(v) for v in value]
    if isinstance(value, dict):
        return {_mended(k): _mended(v) for k, v in value.items()}
    return value
