"""Session 22: a navigator whose next_step cannot be called as next_step(obs) is refused
before anything connects (docs/navigators.md), as a plain function or a plug-in by name,
at the API and at the command line (exit 2)."""

from __future__ import annotations

from typing import Any

import pytest

import pirate_bt
from pirate_bt.api import navigation
from pirate_bt.cli import main
from pirate_bt.errors import ArgumentTypeError


class NoObservation:
    def next_step(self) -> None:  # pragma: no cover - never called
        return None


class TwoArguments:
    def next_step(self, obs: object, extra: object) -> None:  # pragma: no cover
        return None


class CallableStep:
    """A next_step that is a callable object of the wrong arity."""

    class _Decide:
        def __call__(self) -> None:  # pragma: no cover - never called
            return None

    next_step = _Decide()


@pytest.fixture
def connected(monkeypatch: pytest.MonkeyPatch) -> list[Any]:
    """What connect() was called with (it was, before the refusal)."""
    calls: list[Any] = []

    def refuse(*args: Any, **kwargs: Any) -> Any:
        calls.append(args)
        raise AssertionError("connected before the navigator was checked")

    monkeypatch.setattr(navigation, "connect", refuse)
    return calls


@pytest.mark.parametrize(
    ("made", "signature"),
    [
        (NoObservation, "()"),
        (TwoArguments, "(obs: 'object', extra: 'object')"),
        (CallableStep, "()"),
    ],
    ids=["none", "two", "callable"],
)
def test_a_next_step_of_the_wrong_arity_is_refused_before_anything_connects(
    connected: list[Any], made: type, signature: str
) -> None:
    # was a run that connected, then failed: "navigator 'NoObservation' raised
    # TypeError: NoObservation.next_step() takes 1 positional argument but 2 were given"
    with pytest.raises(ArgumentTypeError) as caught:
        pirate_bt.navigate(made(), sim="straight")
    assert str(caught.value) == (
        f"navigate: {made.__name__}.next_step{signature} cannot be called as"
        " next_step(obs); give it one argument, the observation"
    )
    assert connected == []


def test_a_plug_in_s_next_step_of_the_wrong_arity_is_refused_at_the_command_line(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], connected: list[Any]
) -> None:
    from importlib.metadata import EntryPoint

    from pirate_bt.task import navigators as registry

    plugin = EntryPoint(
        name="rogue", value=f"{__name__}:NoObservation", group=registry.ENTRY_POINT_GROUP
    )
    monkeypatch.setattr(registry, "entry_points", lambda group: [plugin])
    assert main(["navigate", "rogue", "--sim", "straight", "-q"]) == 2
    assert capsys.readouterr().err == (
        "pirate-bt: navigator 'rogue': next_step() cannot be called as next_step(obs);"
        " give it one argument, the observation\n"
    )
    assert connected == []
