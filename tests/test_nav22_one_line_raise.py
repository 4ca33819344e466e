"""Session 22: a ``check_map`` that refuses a map with a ``raise`` written on the line
of its condition (``if network is not None: raise ValueError(...)``, or a one-line
``def``) is a refusal of the map, said in its own words (docs/navigators.md); it was
said as the navigator's bug, *check_map raised ValueError: ... (at FILE:LINE)*, as
only a line that begins with ``raise`` was taken for one. Python's own error on a
line of the check is still the navigator's bug, with its place."""

from __future__ import annotations

import importlib.util
import textwrap
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest

import pirate_bt
from pirate_bt.api import navigation
from pirate_bt.errors import InputError

PLANNER = textwrap.dedent(
    """
    class OneLine:
        def check_map(self, network):
            if network is not None: raise ValueError("not this map: I survey")
        def next_step(self, obs):
            return None

    class OneLineDef:
        @classmethod
        def check_map(cls, network): raise TypeError("give me no map")
        def next_step(self, obs):
            return None

    class Buggy:
        def check_map(self, network):
            if network is not None: int("not a number")
        def next_step(self, obs):
            return None
    """
)


@pytest.fixture
def planner(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> ModuleType:
    """The navigators, from a planner's file of its own (not formatted as ours are)."""

    def refuse(*args: Any, **kwargs: Any) -> Any:
        raise AssertionError("connected before check_map was asked")

    monkeypatch.setattr(navigation, "connect", refuse)
    path = tmp_path / "planner22.py"
    path.write_text(PLANNER)
    spec = importlib.util.spec_from_file_location("planner22", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.parametrize(
    ("made", "said"),
    [
        ("OneLine", "navigator 'OneLine': not this map: I survey"),
        ("OneLineDef", "navigator 'OneLineDef': give me no map"),
    ],
    ids=["if-then-raise", "one-line-def"],
)
def test_a_raise_on_the_line_of_its_condition_is_a_refusal(
    planner: ModuleType, made: str, said: str
) -> None:
    with pytest.raises(InputError) as caught:
        pirate_bt.navigate(getattr(planner, made)(), map="straight")
    assert str(caught.value) == said


def test_python_s_own_error_on_a_line_of_the_check_is_still_a_bug_with_its_place(
    planner: ModuleType,
) -> None:
    with pytest.raises(InputError) as caught:
        pirate_bt.navigate(planner.Buggy(), map="straight")
    assert str(caught.value).startswith(
        "navigator 'Buggy': check_map raised ValueError: invalid literal for int() with"
        " base 10: 'not a number' (at "
    )
    assert str(caught.value).endswith("planner22.py:16)")
