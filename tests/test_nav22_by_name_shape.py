"""Session 22: a navigator made by name whose ``next_step`` cannot be called as
``next_step(obs)`` (the wrong arity, an ``async def``, a ``yield``) is refused as it is
made (:func:`pirate_bt.load_navigator`), so a campaign refuses it at its run before any
case: ``validate`` said *ok*, and ``pirate-bt campaign`` ran every case to an error row
(*navigate: Bad.next_step() cannot be called ...*) and ended with exit 0
(docs/navigators.md)."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

import pirate_bt
from pirate_bt.cli import main
from pirate_bt.errors import InputError
from pirate_bt.task import navigators as registry


class OneLess:
    def next_step(self) -> None:  # pragma: no cover - never called
        return None


class Awaits:
    async def next_step(self, obs: Any) -> None:  # pragma: no cover - never called
        return None


class Yields:
    def next_step(self, obs: Any) -> Iterator[None]:  # pragma: no cover - never called
        yield None


@pytest.mark.parametrize(
    ("made", "said"),
    [
        (
            OneLess,
            "next_step() cannot be called as next_step(obs); give it one argument, the observation",
        ),
        (
            Awaits,
            "next_step is async def; write it as a plain def that returns a Step, or None"
            " when done",
        ),
        (Yields, "next_step yields; write it to return a Step, or None when done"),
    ],
    ids=["arity", "async", "yields"],
)
def test_a_navigator_by_name_whose_next_step_cannot_be_called_is_refused_as_made(
    monkeypatch: pytest.MonkeyPatch, made: type, said: str
) -> None:
    monkeypatch.setitem(registry._BUILT_IN, "shaped", made)
    with pytest.raises(InputError) as caught:
        pirate_bt.load_navigator("shaped")
    assert str(caught.value) == f"navigator 'shaped': {said}"


def test_a_campaign_refuses_it_at_its_run_before_any_case(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setitem(registry._BUILT_IN, "oneless", OneLess)  # made in this process
    spec = tmp_path / "n.campaign.yaml"
    spec.write_text("name: n\nruns:\n  - {name: r, navigator: oneless, network: straight}\n")
    assert main(["validate", str(spec)]) == 2
    assert capsys.readouterr().err.endswith(
        "run 'r': navigator 'oneless': next_step() cannot be called as next_step(obs); give"
        " it one argument, the observation\n"
    )
