"""Session 22: a ``next_step`` that is a callable object whose ``__call__`` is an
``async def`` or yields is refused before anything connects, as such a method is
(docs/navigators.md): it connected, the navigation failed on its first answer (*a
navigator returned a coroutine (A.__call__), not a Step*, exit 1), and the coroutine
left *RuntimeWarning: coroutine 'A.__call__' was never awaited*."""

from __future__ import annotations

import warnings
from collections.abc import Iterator
from typing import Any

import pytest

import pirate_bt
from pirate_bt.api import navigation
from pirate_bt.errors import InputError


class _Yields:
    def __call__(self, obs: Any) -> Iterator[Any]:  # pragma: no cover - never called
        yield None


class _Async:
    async def __call__(self, obs: Any) -> None:  # pragma: no cover - never called
        return None


class Yielding:
    next_step = _Yields()


class Awaiting:
    next_step = _Async()


@pytest.mark.parametrize(
    ("made", "said"),
    [
        (
            Yielding,
            "navigate: Yielding.next_step yields; write it to return a Step, or None when done",
        ),
        (
            Awaiting,
            "navigate: Awaiting.next_step is async def; write it as a plain def that returns"
            " a Step, or None when done",
        ),
    ],
    ids=["yields", "async"],
)
def test_a_callable_next_step_that_never_runs_is_refused_before_anything_connects(
    monkeypatch: pytest.MonkeyPatch, made: type, said: str
) -> None:
    def refuse(*args: Any, **kwargs: Any) -> Any:
        raise AssertionError("connected before next_step was checked")

    monkeypatch.setattr(navigation, "connect", refuse)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no coroutine left never awaited
        with pytest.raises(InputError) as caught:
            pirate_bt.navigate(made(), sim="straight")
    assert str(caught.value) == said
