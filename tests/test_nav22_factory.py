"""Session 22: a navigator's entry point that makes a class, not an instance (a factory
function that returns ``Planner`` where it meant ``Planner()``), is refused as
``navigate(Planner)`` is, naming the navigator and the class (docs/navigators.md); it was
*navigate: type.next_step(self, obs) cannot be called as next_step(obs)*, a class named
``type``."""

from __future__ import annotations

from typing import Any

import pytest

import pirate_bt
from pirate_bt.api import navigation
from pirate_bt.errors import InputError
from pirate_bt.task import navigators as registry


class Planner:
    def next_step(self, obs: Any) -> None:  # pragma: no cover - never made
        return None


def makes_the_class(**params: Any) -> type:
    return Planner  # meant Planner()


def test_a_factory_that_makes_a_class_is_refused_naming_it(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    def refuse(*args: Any, **kwargs: Any) -> Any:
        raise AssertionError("connected")

    monkeypatch.setattr(navigation, "connect", refuse)
    monkeypatch.setitem(registry._BUILT_IN, "classy", makes_the_class)
    with pytest.raises(InputError) as caught:
        pirate_bt.navigate("classy", sim="straight")
    assert str(caught.value) == (
        "navigator 'classy' made the class Planner, not a navigator: its entry point"
        " should make an instance (Planner(...))"
    )
