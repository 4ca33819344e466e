"""A navigator's error without words ends at its type; a plug-in that takes a built-in
navigator's name is said to be shadowed, not silently passed over."""

from __future__ import annotations

import logging
from types import SimpleNamespace

import pytest

import pirate_bt
from pirate_bt.task import navigators
from pirate_bt.task.navigation import Observation, Step


class _Wordless:
    def next_step(self, obs: Observation) -> Step | None:
        raise ValueError()


class _Lines:
    def next_step(self, obs: Observation) -> Step | None:
        raise RuntimeError("lost\n  its\tway")


def test_an_error_without_words_ends_at_its_type() -> None:
    result = pirate_bt.navigate(_Wordless(), sim="straight")
    assert not result.succeeded
    assert result.why == "navigator '_Wordless' raised ValueError"


def test_an_error_of_several_lines_is_one_line() -> None:
    result = pirate_bt.navigate(_Lines(), sim="straight")
    assert result.why == "navigator '_Lines' raised RuntimeError: lost its way"


def test_a_plug_in_with_a_built_in_name_is_said_to_be_shadowed(
    monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    fake = SimpleNamespace(value="their_pkg.nav:Goal")
    monkeypatch.setattr(navigators, "_registered", lambda: {"goal": fake})
    with caplog.at_level(logging.WARNING, logger=navigators._log.name):
        made = navigators.load_navigator("goal", {"segment": "pipe"})
    assert type(made) is navigators.GoalNavigator
    assert "the plug-in of that name (their_pkg.nav:Goal) is shadowed" in caplog.text
