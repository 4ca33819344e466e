"""Standard output that cannot be written: a reader that went away, a full device.

``pirate-bt robot | head -1`` closes the pipe after one line, and ``pirate-bt schema
hardware > /dev/full`` writes onto a full device. Python leaves both to the exit of
the interpreter: an ``Exception ignored ... BrokenPipeError`` (or ``OSError``) and
exit status 120 instead of the command's, a traceback from ``--help``, or, for a
text buffered whole, nothing at all and exit 0 though nothing was written.

:func:`watched` lets :func:`pirate_bt.cli.main` tell a failed write to standard output
(no file name in the error) from any other, and :func:`finish` flushes both streams
before the interpreter does: a reader that went away is no error (the command's exit
code stands), a write that failed is one line naming standard output, exit 2 (a
file that could not be written). Standard error never stops a command: what cannot
be written there (a full log disk) is lost, and the command runs on to its verdict.
"""

from __future__ import annotations

import contextlib
import os
import sys
from collections.abc import Iterator
from typing import Any, TextIO

__all__ = ["STDOUT_NAME", "describe", "finish", "stdout_failure", "watched"]

STDOUT_NAME = "standard output"


class _Watched:
    """A text stream that remembers the error its last failed write or flush raised."""

    def __init__(self, stream: TextIO) -> None:
        self._stream = stream
        self.failure: OSError | None = None

    def write(self, text: str) -> int:
        try:
            return _write(self._stream, text)
        except OSError as exc:
            self.failure = exc
            raise

    def flush(self) -> None:
        try:
            self._stream.flush()
        except OSError as exc:
            self.failure = exc
            raise

    def __getattr__(self, name: str) -> Any:  # fileno, isatty, encoding, ...
        return getattr(self._stream, name)


class _Unheard(_Watched):
    """Standard error, which never stops the command: a reader that went away (``2>&1
    | head -1``) sends what is written after to nowhere, and a write that fails (``2>>
    log`` on a full disk) loses that message only; the command goes on to its end and
    its exit code. The live view of a run writes here: a full log disk stopped the run
    mid-pipe (exit 1) where it would have succeeded."""

    def write(self, text: str) -> int:
        try:
            return _write(self._stream, text)
        except BrokenPipeError:
            _discard(self._stream)
        except OSError:
            pass
        return len(text)

    def flush(self) -> None:
        try:
            self._stream.flush()
        except BrokenPipeError:
            _discard(self._stream)
        except OSError:
            pass


def _write(stream: TextIO, text: str) -> int:
    """``text`` written; what the stream's encoding cannot carry (a degree sign or
    ``▶`` with ``PYTHONIOENCODING=ascii`` or a Latin-1 terminal, half a UTF-16 pair)
    written as a backslash escape (``\\u25b6``), where it was an internal error."""
    try:
        return stream.write(text)
    except UnicodeEncodeError:
        encoding = getattr(stream, "encoding", None) or "utf-8"
        escaped = text.encode(encoding, "backslashreplace").decode(encoding, "replace")
        stream.write(escaped)
        return len(text)


_watching: list[_Watched] = []  # the stream watched during the last command


@contextlib.contextmanager
def watched() -> Iterator[None]:
    """``sys.stdout`` watched for failed writes, and ``sys.stderr`` written to nowhere
    once its reader has gone, while the command runs; the streams before them are
    back afterwards (``main`` also runs inside tests)."""
    before, before_err = sys.stdout, sys.stderr
    stream, err = _Watched(before), _Unheard(before_err)
    sys.stdout, sys.stderr = stream, err
    _watching[:] = [stream]
    try:
        yield
    finally:
        if sys.stdout is stream:
            sys.stdout = before
        if sys.stderr is err:
            sys.stderr = before_err


def stdout_failure(exc: BaseException) -> bool:
    """Whether ``exc`` is the error the last write to standard output raised, while or
    after the command ran."""
    return bool(_watching) and _watching[-1].failure is exc


def describe(exc: OSError) -> str:
    """One line for a write to standard output that failed: ``standard output: why``."""
    return f"{STDOUT_NAME}: {exc.strerror or type(exc).__name__}"


def _discard(stream: TextIO) -> None:
    """Later writes to ``stream``, and the interpreter's flush at exit, go nowhere."""
    with contextlib.suppress(OSError, ValueError, AttributeError):
        null = os.open(os.devnull, os.O_WRONLY)
        try:
            os.dup2(null, stream.fileno())
        finally:
            os.close(null)


def finish(code: int) -> int:
    """Flush standard output and error now; returns the exit code to leave with.

    A reader that went away (``| head -1``) leaves ``code`` as it is; any other
    failure to write standard output is one line naming it, and exit 2 if the command
    had succeeded.
    """
    try:
        sys.stdout.flush()
    except BrokenPipeError:
        _discard(sys.stdout)
    except OSError as exc:
        _discard(sys.stdout)
        with contextlib.suppress(OSError):
            print(f"pirate-bt: {describe(exc)}", file=sys.stderr)
        code = 2 if code == 0 else code
    try:
        sys.stderr.flush()
    except OSError:
        _discard(sys.stderr)
    return code
