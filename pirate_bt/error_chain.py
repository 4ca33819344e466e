"""A result's ``error`` sent to another process with the causes it was raised from.

Python pickles an exception as its type, arguments and attributes: ``__cause__`` (a
``raise ... from e``) and ``__context__`` (raised while handling another) are left
behind. A result sent back from a process pool's worker then said *RuntimeError: no
way to the goal* with the ``KeyError`` that started it gone, where the same result in
the calling process kept it. :func:`portable_chained` stands, in the state a result
pickles, for its error, and reads back as that error with its causes attached again
(each made portable as the error is: :func:`~pirate_bt.errors.portable_error`).
"""

from __future__ import annotations

from dataclasses import fields
from typing import Any

from pirate_bt.errors import portable_error

__all__ = ["MAX_CAUSES", "error_key", "hash_values", "portable_chained", "same_values"]

MAX_CAUSES = 16
"""How many causes back a chain is kept (a cycle, or a runaway chain, stops there)."""


class _Chained:
    """An exception and its causes, as pickled: read back, the exception itself."""

    __slots__ = ("cause", "context", "error", "suppress")

    def __init__(self, error: object, cause: object, context: object, suppress: bool) -> None:
        self.error = error
        self.cause = cause
        self.context = context
        self.suppress = suppress

    def __reduce__(self) -> tuple[Any, ...]:
        return (_rechained, (self.error, self.cause, self.context, self.suppress))


def _rechained(
    error: BaseException, cause: object, context: object, suppress: bool
) -> BaseException:
    if isinstance(cause, BaseException):
        error.__cause__ = cause
    if isinstance(context, BaseException):
        error.__context__ = context
    error.__suppress_context__ = suppress
    return error


def portable_chained(error: object) -> Any:
    """What a result's ``__getstate__`` keeps for ``error``: the error itself (or its
    stand-in, :func:`~pirate_bt.errors.portable_error`) when it has no cause, else an
    object that pickles as the error with its causes, each portable too."""
    return _portable(error, set())


def _portable(error: object, seen: set[int]) -> object:
    if not isinstance(error, BaseException):  # None, or made so already (a loop's error)
        return error
    portable = portable_error(error)
    seen.add(id(error))
    cause, context = error.__cause__, error.__context__
    if len(seen) > MAX_CAUSES or (cause is None and context is None):
        return portable
    kept_cause = None if cause is None or id(cause) in seen else _portable(cause, seen)
    if context is cause:  # raise ... from e inside except e: one exception, kept once
        kept_context = kept_cause
    else:
        kept_context = None if context is None or id(context) in seen else _portable(context, seen)
    return _Chained(portable, kept_cause, kept_context, error.__suppress_context__)


def error_key(error: object, depth: int = MAX_CAUSES) -> object:
    """What two errors are compared by in results that compare by value: the type, the
    message and the causes; an exception compares by identity, so a result read back
    in another process (a copy of its error) was not equal to its original."""
    if not isinstance(error, BaseException) or depth <= 0:
        return error
    kind = type(error)
    return (
        f"{kind.__module__}.{kind.__qualname__}",
        str(error),
        error_key(error.__cause__, depth - 1),
        None if error.__context__ is error.__cause__ else error_key(error.__context__, depth - 1),
    )


def same_values(one: Any, other: Any) -> bool:
    """Whether two dataclass results of one type hold equal values, field by compared
    field, their exceptions by :func:`error_key` (the dataclass's own ``__eq__`` compared
    an exception by identity)."""
    return all(
        error_key(getattr(one, f.name)) == error_key(getattr(other, f.name))
        for f in fields(one)
        if f.compare
    )


def hash_values(one: Any) -> int:
    """The hash that goes with :func:`same_values` (exceptions by :func:`error_key`)."""
    return hash(
        tuple(
            error_key(getattr(one, f.name))
            for f in fields(one)
            if f.hash is not False and f.compare
        )
    )
