"""Session 22: a navigator's ``check_map`` is checked for its shape before it is called,
as ``next_step`` is (docs/navigators.md): one with a ``yield`` (a generator function,
whose body never runs) was silently taken for a check that passed, and one of the wrong
arity was said as a ``TypeError`` raised in pirate_bt's own file (*at
pirate_bt/task/navigators.py:429*). Both are refused before anything connects, exit 2,
from ``navigate()``, the command line and a campaign."""

from __future__ import annotations

from importlib.metadata import EntryPoint
from pathlib import Path
from typing import Any

import pytest

import pirate_bt
from pirate_bt.api import navigation
from pirate_bt.cli import main
from pirate_bt.errors import InputError
from pirate_bt.task import navigators as registry


class Yields:
    def check_map(self, m: Any) -> Any:
        raise ValueError("this map is not for me")
        yield  # a generator function: calling it runs none of the above

    def next_step(self, obs: Any) -> None:  # pragma: no cover - never runs
        return None


class NoMap:
    def check_map(self) -> None:  # pragma: no cover - never called
        return None

    def next_step(self, obs: Any) -> None:  # pragma: no cover - never runs
        return None


class TwoMaps:
    def check_map(self, m: Any, other: Any) -> None:  # pragma: no cover - never called
        return None

    def next_step(self, obs: Any) -> None:  # pragma: no cover - never runs
        return None


class _Checker:
    def __call__(self, m: Any) -> Any:
        raise ValueError("never runs")
        yield


class CallableYields:
    """A check_map that is a callable object whose __call__ yields."""

    check_map = _Checker()

    def next_step(self, obs: Any) -> None:  # pragma: no cover - never runs
        return None


class ReturnsGenerator:
    """A check_map that hands back a generator made elsewhere: no check ran."""

    def check_map(self, m: Any) -> Any:
        return (None for _ in ())

    def next_step(self, obs: Any) -> None:  # pragma: no cover - never runs
        return None


@pytest.fixture
def connected(monkeypatch: pytest.MonkeyPatch) -> list[Any]:
    calls: list[Any] = []

    def refuse(*args: Any, **kwargs: Any) -> Any:
        calls.append(args)
        raise AssertionError("connected before check_map was checked")

    monkeypatch.setattr(navigation, "connect", refuse)
    return calls


_YIELDS = "check_map yields, and its check never ran; write it as a plain def that raises"
_YIELDS += " ValueError to refuse a map"


@pytest.mark.parametrize(
    ("made", "said"),
    [
        (Yields, f"navigator 'Yields': {_YIELDS}"),
        (CallableYields, f"navigator 'CallableYields': {_YIELDS}"),
        (ReturnsGenerator, f"navigator 'ReturnsGenerator': {_YIELDS}"),
        (
            NoMap,
            "navigator 'NoMap': check_map() cannot be called as check_map(map); give it"
            " one argument, the map",
        ),
        (
            TwoMaps,
            "navigator 'TwoMaps': check_map(m: 'Any', other: 'Any') cannot be called as"
            " check_map(map); give it one argument, the map",
        ),
    ],
    ids=["yields", "callable-yields", "returns-generator", "no-argument", "two-arguments"],
)
def test_a_check_map_of_the_wrong_shape_is_refused_before_anything_connects(
    connected: list[Any], made: type, said: str
) -> None:
    with pytest.raises(InputError) as caught:
        pirate_bt.navigate(made(), map="straight")
    assert str(caught.value) == said
    assert connected == []


def test_a_plug_in_s_check_map_that_yields_is_refused_at_the_command_line(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], connected: list[Any]
) -> None:
    plugin = EntryPoint(name="yields", value=f"{__name__}:Yields", group=registry.ENTRY_POINT_GROUP)
    monkeypatch.setattr(registry, "entry_points", lambda group: [plugin])
    assert main(["navigate", "yields", "--map", "straight", "-q"]) == 2
    assert capsys.readouterr().err == f"pirate-bt: navigator 'yields': {_YIELDS}\n"
    assert connected == []


def test_a_campaign_s_check_map_of_the_wrong_arity_is_refused_at_its_run(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setitem(registry._BUILT_IN, "nomap", NoMap)  # made in this process
    spec = tmp_path / "n.campaign.yaml"
    spec.write_text("name: n\nruns:\n  - {name: r, navigator: nomap, network: straight}\n")
    assert main(["validate", str(spec)]) == 2
    err = capsys.readouterr().err
    assert err.endswith(
        "run 'r': navigator 'nomap': check_map() cannot be called as check_map(map); give"
        " it one argument, the map\n"
    )
    assert "navigators.py" not in err and "navigate_checks.py" not in err
