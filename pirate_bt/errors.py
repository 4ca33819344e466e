"""One error hierarchy for the whole library.

Every error ``pirate_bt`` raises on purpose derives from :class:`PirateError`, so
planner code can catch the library's failures in one ``except`` and let real bugs
through. Each class carries the command-line exit code that DESIGN.md assigns to
its kind of failure, so the CLI never has to guess::

    PirateError                      (exit 1)
     ├── InputError                  (exit 2)  a file, an option or a value is wrong
     │    ├── ArgumentTypeError                an argument of the wrong type (a TypeError)
     │    ├── ArgumentValueError               an argument's value refused (a ValueError)
     │    ├── LocatedError                     one problem at file:line:column
     │    ├── ValidationFailed                 several LocatedErrors for one file
     │    └── UnitError                        unknown unit or wrong dimension
     ├── ConfigurationError          (exit 2)  consistent files that cannot work together
     ├── LinkError                   (exit 3)  the link to the robot or bridge
     │    ├── FrameError                       a frame that cannot be decoded
     │    ├── ProtocolMismatch                 the peer speaks another version or layout
     │    ├── LinkTimeout                      also a built-in TimeoutError
     │    └── LinkLost                         nothing heard for longer than allowed
     ├── SafetyError                 (exit 1)  the protective layer said no
     │    ├── CommandRefused                   with a machine-readable reason
     │    └── EStopLatched                     nothing moves until an operator resets
     └── ExecutionError              (exit 1)  a tree or mission failed at run time

A timeout is also a :class:`TimeoutError`, so generic code that already handles
timeouts keeps working (the same choice python-can makes).

Problems in input are located: :class:`LocatedError` names the ``file:line:column``
of one problem and :class:`ValidationFailed` carries every problem of one input.
Input written in Python (a node built with ``Clamp.build(...)``, parameters given
to ``load_tree(...)``) is located at the caller's source line, found with
:func:`caller_location`.

A public function refuses a bad argument at its boundary with one line that names
the argument (docs/api.md, *Arguments the API refuses*); the layers below the API
share :func:`shown` (a value cut to about 40 characters and its length, never an
unbounded echo) and :func:`file_argument` (a file name: text or a path, not empty,
no NUL, at most :data:`MAX_PATH` characters).
"""

from __future__ import annotations

import contextlib
import math
import operator
import os
import pickle
import re
import sys
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from types import FrameType
from typing import Any

__all__ = [
    "MAX_PATH",
    "MAX_SEED",
    "REASON_LIMIT",
    "ArgumentTypeError",
    "ArgumentValueError",
    "CommandRefused",
    "ConfigurationError",
    "EStopLatched",
    "ExecutionError",
    "FrameError",
    "InputError",
    "LinkError",
    "LinkLost",
    "LinkTimeout",
    "LocatedError",
    "PirateError",
    "ProtocolMismatch",
    "SafetyError",
    "SourceLocation",
    "UnitError",
    "UnpicklableError",
    "ValidationFailed",
    "bytes_escaped",
    "caller_location",
    "cut_reason",
    "file_argument",
    "kind_of",
    "output_argument",
    "portable_error",
    "reduce_error",
    "said_of",
    "seed_argument",
    "shown",
]


def _rebuilt(cls: type[BaseException], args: tuple[Any, ...], state: dict[str, Any]) -> Any:
    """``cls``'s error with ``args`` and ``state``, made without calling its ``__init__``
    (see :func:`reduce_error`)."""
    error = cls.__new__(cls, *args)
    error.args = args
    error.__dict__.update(state)
    return error


def reduce_error(error: BaseException) -> tuple[Any, ...]:
    """``__reduce__`` of an error whose ``__init__`` takes other arguments than its
    ``args``: it is rebuilt from its ``args`` and attributes, so it goes to and comes
    back from another process (a process pool, Dask) whole. Python's own reduction
    calls ``cls(*args)``, which for such an error raises as the other process reads it
    back, and a process pool then breaks (``BrokenProcessPool``) and loses every result
    (until 2026-11-30, a ``NodeLookupError`` raised in a pool's worker)."""
    return (_rebuilt, (type(error), error.args, dict(error.__dict__)))


class PirateError(Exception):
    """Base of every error the library raises on purpose.

    Each one, of any subclass, can be pickled and read back whole (its message, its
    attributes), as a process pool or Dask sends it (:func:`reduce_error`)."""

    exit_code: int = 1

    def __reduce__(self) -> tuple[Any, ...]:
        return reduce_error(self)


class InputError(PirateError):
    """Invalid input from a user: a file, a command-line option or a value."""

    exit_code = 2


class ArgumentTypeError(InputError, TypeError):
    """An argument of the wrong type, refused at a public function's boundary.

    Also a ``TypeError``, which such a mistake raised before it was checked.
    """


class ArgumentValueError(InputError, ValueError):
    """An argument whose value is refused at a public function's boundary.

    Also a ``ValueError``, which such a value raised before it was checked.
    """


MAX_PATH = 4096
"""The longest file name an argument may be (PATH_MAX on Linux; the API's
``pirate_bt.api.options.MAX_PATH`` is the same)."""

MAX_SEED = 2**63 - 1
"""The largest seed (seeds are whole numbers from 0): the API's, a campaign's and the
simulator's (``pirate_bt.api.options.MAX_SEED`` is this one)."""

_SHOWN = 40


REASON_LIMIT = 1000
"""The most characters of a run's stop message (and of the safe-state reason a runner
gives): a node's exception or feedback can say anything, 100 kB included."""


def cut_reason(text: str, limit: int = REASON_LIMIT) -> str:
    """``text`` in at most ``limit`` characters: its middle left out, saying how much,
    as the API's ``why`` is cut (:func:`pirate_bt.behaviours.foreign.one_line`). The
    start (the node, the first cause) and the end (what was raised: after a long node
    path) are both kept: ``RuntimeError in boom: xxx...(99024 characters)...x the end``."""
    if len(text) <= limit:
        return text
    mark = f"...({len(text)} characters)..."
    half = max(0, (limit - len(mark)) // 2)
    left = len(text) - 2 * half
    return f"{text[:half]}...({left} characters)...{text[len(text) - half :]}"


def kind_of(value: object) -> str:
    """What ``value`` is, for a message: ``None``, ``an int``, ``a float``."""
    if value is None:
        return "None"
    name = type(value).__name__
    return f"{'an' if name[:1].lower() in 'aeiou' else 'a'} {name}"


def digit_count(number: int) -> int:
    """How many decimal digits ``number`` has, without ``str()`` (which raises beyond
    4300 digits, so a message about a huge number raised instead of saying so)."""
    size = abs(number)
    if size < 10:
        return 1
    count = int((size.bit_length() - 1) * math.log10(2)) + 1  # exact or one short
    while 10 ** (count - 1) > size:
        count -= 1
    while 10**count <= size:
        count += 1
    return count


def said_of(exc: BaseException, limit: int | None = None) -> str:
    """An exception's message on one line (whitespace folded), cut to ``limit``
    characters with ``...``; what can be said of it when its ``__str__`` raises
    (planner code's own exception class: a bare ``RuntimeError`` escaped ``navigate()``
    from there)."""
    try:
        text = " ".join(str(exc).split())
    except Exception:
        text = f"<its message cannot be shown: {type(exc).__name__}.__str__ raised>"
    return text if limit is None or len(text) <= limit else text[: limit - 3] + "..."


_ADDRESSED = re.compile(r"<.* at 0x[0-9a-fA-F]+>", re.DOTALL)


def bytes_escaped(text: str) -> str:
    """``text`` with the bytes that are no UTF-8 of a name the system gave
    (``os.fsdecode`` reads ``$'\\xff.yaml'`` as ``'\\udcff.yaml'``) shown as ``\\xff``:
    text that can be written to a file or a terminal, where the lone surrogate made
    an ``internal error: UnicodeEncodeError``."""
    return text.encode("utf-8", "surrogateescape").decode("utf-8", "backslashreplace")


def shown(value: object, limit: int = _SHOWN) -> str:
    """``repr(value)`` for a message, cut to ``limit`` characters and its length when
    longer: ``'xxxx...' (100000 characters)``. A huge whole number gives its digits'
    count, a value whose ``repr`` fails its type, and one whose ``repr`` is only its
    type and address (``<Planner object at 0x7f...>``) its type (``a Planner``; a
    coroutine or a function with its name: ``a coroutine (Planner.next_step)``)."""
    if isinstance(value, int) and not isinstance(value, bool) and abs(value) >= 10**limit:
        return f"a {digit_count(value)}-digit number"
    if isinstance(value, str | bytes) and len(value) > limit:
        return f"{value[:limit]!r}... ({len(value)} characters)"
    try:
        text = repr(value)
    except Exception:  # a repr of the caller's own that fails
        return kind_of(value)
    if _ADDRESSED.fullmatch(text):  # object's own repr: its address tells a person nothing
        named = getattr(value, "__qualname__", None)  # a function's, a coroutine's
        return f"{kind_of(value)} ({named})" if isinstance(named, str) else kind_of(value)
    if len(text) > limit:
        return f"{text[:limit]}... ({kind_of(value)})"
    return text


def file_argument(value: object, option: str) -> Path:
    """A file name given as an argument: text or a path, not empty, no NUL, at most
    :data:`MAX_PATH` characters (the rules of ``pirate_bt.api.options.file_name``).

    Raises:
        ArgumentTypeError: neither text nor a path (a number, a mapping, bytes).
        ArgumentValueError: empty, with a NUL, too long, or ``-`` where no file of that
            name is (standard input or output); named by ``option``.
    """
    if not isinstance(value, str | os.PathLike):
        raise ArgumentTypeError(
            f"{option}: give a file name (text or a Path), not {kind_of(value)}"
        )
    text = os.fspath(value)
    if not isinstance(text, str):
        raise ArgumentTypeError(f"{option}: give a file name as text, not bytes")
    if not text.strip():
        raise ArgumentValueError(f"{option}: the file name is empty")
    if "\0" in text:
        raise ArgumentValueError(f"{option}: a file name may not hold a NUL character")
    if len(text) > MAX_PATH:
        raise ArgumentValueError(
            f"{option}: a file name of {len(text)} characters is too long (at most {MAX_PATH})"
        )
    if text == "-" and not os.path.lexists(text):  # was "no such file", or a bundled lookup
        raise ArgumentValueError(
            f"{option}: '-' is no file here (files are read and written by name, not through"
            " standard input or output); name the file"
        )
    return Path(text)


def output_argument(value: object, option: str) -> Path:
    """A file to write, given as an argument: :func:`file_argument`, not a folder, no
    file on its way.

    Raises:
        ArgumentTypeError: not a file name.
        ArgumentValueError: a bad name, a folder, or a file on its way.
        InputError: a name the system refuses (a part longer than 255 bytes).
    """
    path = file_argument(value, option)
    try:
        if path.is_dir():
            raise ArgumentValueError(
                f"{option}: {shown(str(path), MAX_PATH)} is a folder; name a file"
            )
        for parent in path.parents:
            if parent.exists():
                if not parent.is_dir():
                    raise ArgumentValueError(
                        f"{option}: {shown(str(parent), MAX_PATH)} is not a folder"
                        f" (on the way to {shown(path.name)})"
                    )
                break
    except OSError as exc:
        raise InputError(
            f"{option}: cannot write {shown(str(path), MAX_PATH)}: {exc.strerror or exc}"
        ) from None
    return path


def seed_argument(seed: object, option: str = "seed") -> int:
    """A seed given as an argument: a whole number from 0 to :data:`MAX_SEED`, the one
    rule of the API's ``seed=`` (``pirate_bt.api.options.seed_value``) and an as-built
    variant's (``pirate_bt.pipes.asbuilt.perturb_network``). Anything with
    ``__index__`` but a bool (a NumPy integer) is a whole number.

    Raises:
        ArgumentTypeError: not a whole number (a bool, a float, text).
        ArgumentValueError: negative or above :data:`MAX_SEED` (``random.Random``
            seeds by a number's size, so -1 was seed 1 under another name).
    """
    if not isinstance(seed, bool) and hasattr(type(seed), "__index__"):
        with contextlib.suppress(Exception):  # its own __index__ raises: no whole number
            seed = operator.index(seed)  # type: ignore[arg-type]
    said = f"{option}: give a whole number from 0 to 2**63 - 1, not {shown(seed)}"
    if isinstance(seed, bool) or not isinstance(seed, int):
        raise ArgumentTypeError(said)
    if not 0 <= seed <= MAX_SEED:
        raise ArgumentValueError(said)
    return seed


@dataclass(frozen=True, slots=True)
class SourceLocation:
    """A place in a text file (or in Python source); line and column count from 1.

    ``str()`` gives ``file:line:column``, the form editors and terminals link to.

    Attributes:
        file: The file as shown to people: the path as given (relative paths stay
            relative), or a pseudo-file for input that is not in a file, such as
            ``--param`` (a command-line option) or ``<dict>`` (a tree given as a
            mapping).
        line: The line, from 1 (1 when the problem concerns the whole input).
        column: The column, from 1 (1 when only the line is known, as for Python
            callers).
    """

    file: str
    line: int = 1
    column: int = 1

    def __str__(self) -> str:
        file = self.file
        if not file.isprintable():
            # a name with an escape sequence or a line break (given on the command line,
            # or a subtree's ref) is shown escaped: it reaches no terminal as written
            file = "".join(c if c.isprintable() else repr(c)[1:-1] for c in bytes_escaped(file))
        return f"{file}:{self.line}:{self.column}"


class LocatedError(InputError):
    """One problem at one place, printed as ``file:line:column: message``.

    Args:
        message: What is wrong, for people (see ``message`` below).
        location: Where it is; ``None`` (or left out, as planner code raising one of its
            own may) is the line of Python that made it (``<python>:1:1`` when that is
            pirate_bt's own). It was required, and ``None`` printed ``None: message``.

    Attributes:
        message: What is wrong, without the location; by convention it starts
            with what it is about (``"clamp: torque: 50 N*m is above the bend
            joints' limit 0.8 N*m"``: the node type in a file or the node's name in
            Python, then the parameter).
        location: The :class:`SourceLocation` of the problem.

    ``str(error)`` is ``f"{location}: {message}"``, e.g.
    ``trees/t.yaml:4:34: clamp: torque: 50 N*m is above the bend joints' limit 0.8 N*m``.
    """

    def __init__(self, message: str, location: SourceLocation | None = None) -> None:
        if location is None:
            location = caller_location() or SourceLocation("<python>")
        self.message = message
        self.location = location
        super().__init__(f"{location}: {message}")

    def __reduce__(self) -> tuple[Any, ...]:  # across processes (pools, Dask) intact
        return (type(self), (self.message, self.location))


class ValidationFailed(InputError):
    """An input has one or more located problems; ``errors`` lists all of them.

    Loaders collect every problem they find before raising, so one run shows them
    all; each problem keeps its own location (a tree and its subtree files, or a
    Python caller, may all appear).

    Args:
        errors: The problems, at least one: a list of :class:`LocatedError`, or one.
            A message as text (planner code's own check, ``ValidationFailed("the map
            has no tee")``) is one problem at the line that raised it.

    Attributes:
        errors: A tuple of :class:`LocatedError`, in the order found (files:
            usually file order), without repeats when the loader removed them.

    ``str(exc)`` is the errors' ``str()`` one per line, so printing the exception
    prints every ``file:line:column: message``.

    Raises:
        ValueError: ``errors`` is empty.
        ArgumentTypeError: ``errors`` holds anything but ``LocatedError`` objects (text
            was taken as one problem per character, its letters one per line; a single
            ``LocatedError`` was Python's *not iterable*).
    """

    def __init__(self, errors: Iterable[LocatedError] | LocatedError | str) -> None:
        if isinstance(errors, LocatedError):
            errors = (errors,)
        elif isinstance(errors, str):
            where = caller_location() or SourceLocation("<python>")
            errors = (LocatedError(errors, where),)
        elif not isinstance(errors, Iterable) or isinstance(errors, bytes | bytearray):
            raise ArgumentTypeError(
                f"errors: give LocatedErrors (a list of them), or a message as text, not"
                f" {kind_of(errors)}"
            )
        self.errors: tuple[LocatedError, ...] = tuple(errors)
        if not self.errors:
            raise ValueError("ValidationFailed needs at least one error")
        for error in self.errors:
            if not isinstance(error, LocatedError):
                raise ArgumentTypeError(
                    "errors: each is a LocatedError(message, SourceLocation(file, line,"
                    f" column)), not {kind_of(error)}"
                )
        super().__init__("\n".join(str(e) for e in self.errors))

    def __reduce__(self) -> tuple[Any, ...]:
        return (type(self), (self.errors,))


_PACKAGE_DIR = os.path.dirname(os.path.abspath(__file__))


def _inside(filename: str, *directories: str) -> bool:
    path = os.path.abspath(filename)
    return any(path.startswith(d + os.sep) for d in directories)


def caller_location(
    *, skip: str | Path | tuple[str | Path, ...] | None = None
) -> SourceLocation | None:
    """The place in Python source of the code that called into the library.

    Walks the stack outward from the function that calls this one, past every
    frame whose file is under ``skip``, and returns the first other frame's file
    and line (column 1). The file is shown relative to the working directory when
    it is under it.

    Args:
        skip: The directory (or directories) whose frames are passed over
            (default: the whole ``pirate_bt`` package).

    Returns:
        The caller's place, or ``None`` when that frame is ``pirate_bt``'s own code
        (the library called itself, for instance a command-line command) or the
        stack ran out.
    """
    if skip is None:
        skip = _PACKAGE_DIR
    directories = tuple(os.path.abspath(d) for d in (skip if isinstance(skip, tuple) else (skip,)))
    frame: FrameType | None = sys._getframe(1)
    while frame is not None and _inside(frame.f_code.co_filename, *directories):
        frame = frame.f_back
    if frame is None or _inside(frame.f_code.co_filename, _PACKAGE_DIR):
        return None
    filename = frame.f_code.co_filename
    if os.path.isabs(filename):
        try:
            relative = os.path.relpath(filename)
        except ValueError:  # another drive (Windows)
            relative = filename
        if not relative.startswith(os.pardir + os.sep):
            filename = relative
    return SourceLocation(filename, frame.f_lineno, 1)


class UnitError(InputError):
    """A quantity with an unknown unit, a malformed number or the wrong dimension."""


class ConfigurationError(PirateError):
    """Files that validate one by one but cannot be used together."""

    exit_code = 2


class LinkError(PirateError):
    """The link to the bridge failed: cannot connect, lost, or speaking nonsense."""

    exit_code = 3


class FrameError(LinkError):
    """A received frame is malformed; ``reason`` is a short machine-readable tag."""

    def __init__(self, reason: str, detail: str = "") -> None:
        self.reason = reason
        self.detail = detail
        super().__init__(f"bad frame ({reason}){': ' + detail if detail else ''}")

    def __reduce__(self) -> tuple[Any, ...]:
        return (type(self), (self.reason, self.detail))


class ProtocolMismatch(LinkError):
    """The peer speaks another protocol version or another state layout."""


class LinkTimeout(LinkError, TimeoutError):
    """An operation on the link did not complete within its timeout."""


class LinkLost(LinkError):
    """Nothing valid has been heard from the peer for longer than allowed."""


class SafetyError(PirateError):
    """The protective layer refused to let something through."""


class CommandRefused(SafetyError):
    """A command was refused; ``reason`` is machine-readable, ``detail`` for people."""

    def __init__(self, reason: str, detail: str, command: object = None) -> None:
        self.reason = reason
        self.detail = detail
        self.command = command
        super().__init__(f"refused ({reason}): {detail}")

    def __reduce__(self) -> tuple[Any, ...]:
        return (type(self), (self.reason, self.detail, self.command))


class EStopLatched(SafetyError):
    """The e-stop is latched; only an operator reset releases it."""


class ExecutionError(PirateError):
    """A tree or mission failed while running."""


class UnpicklableError(Exception):
    """Stands in, in a result sent to another process, for the exception that ended its
    run when that one cannot be pickled and read back: its type's name and message."""


def portable_error(error: BaseException | None) -> BaseException | None:
    """``error`` itself when it can be pickled and read back, else a stand-in of the same
    message: a :class:`~pirate_bt.errors.LinkError` for a link error (exit code 3), else
    an :class:`UnpicklableError`."""
    if error is None:
        return None
    try:
        pickle.loads(pickle.dumps(error))
        return error
    except Exception:  # any way a planner's own exception class can refuse
        text = f"{type(error).__name__}: {said_of(error)}"
        return LinkError(text) if isinstance(error, LinkError) else UnpicklableError(text)
