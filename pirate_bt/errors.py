"""One error hierarchy for the whole library.

Every error ``pirate_bt`` raises on purpose derives from :class:`PirateError`, so
planner code can catch the library's failures in one ``except`` and let real bugs
through. Each class carries the command-line exit code that DESIGN.md assigns to
its kind of failure, so the CLI never has to guess::

    PirateError                      (exit 1)
     ├── InputError                  (exit 2)  a file, an option or a value is wrong
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
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

__all__ = [
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
    "ValidationFailed",
]


class PirateError(Exception):
    """Base of every error the library raises on purpose."""

    exit_code: int = 1


class InputError(PirateError):
    """Invalid input from a user: a file, a command-line option or a value."""

    exit_code = 2


@dataclass(frozen=True, slots=True)
class SourceLocation:
    """A place in a text file; line and column count from 1."""

    file: str
    line: int = 1
    column: int = 1

    def __str__(self) -> str:
        return f"{self.file}:{self.line}:{self.column}"


class LocatedError(InputError):
    """One problem at one place in a file, printed as ``file:line:column: message``."""

    def __init__(self, message: str, location: SourceLocation) -> None:
        self.message = message
        self.location = location
        super().__init__(f"{location}: {message}")


class ValidationFailed(InputError):
    """A file has one or more located problems; ``errors`` lists all of them."""

    def __init__(self, errors: Iterable[LocatedError]) -> None:
        self.errors: tuple[LocatedError, ...] = tuple(errors)
        if not self.errors:
            raise ValueError("ValidationFailed needs at least one error")
        super().__init__("\n".join(str(e) for e in self.errors))


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


class EStopLatched(SafetyError):
    """The e-stop is latched; only an operator reset releases it."""


class ExecutionError(PirateError):
    """A tree or mission failed while running."""
