"""Session 22: a plug-in navigator's ``file_params`` (the parameters that name a file,
docs/navigators.md) is read as its author meant or refused in one line: ``"plan"``
(text, where a set was meant) was read as the names 'p', 'l', 'a', 'n', so the plan was
never resolved against the spec's folder, and ``5`` was a bare ``TypeError`` out of
``run_campaign`` (*internal error* at the command line)."""

from __future__ import annotations

from typing import Any

import pytest

from pirate_bt.errors import InputError
from pirate_bt.task import navigators as registry


def _factory(file_params: Any) -> Any:
    class Planner:
        def __init__(self, plan: str = "") -> None:
            self.plan = plan

        def next_step(self, obs: Any) -> None:  # pragma: no cover - never runs
            return None

    Planner.file_params = file_params  # type: ignore[attr-defined]
    return Planner


class _Entry:
    def __init__(self, factory: Any) -> None:
        self.factory = factory
        self.value = "planner22:Planner"

    def load(self) -> Any:
        return self.factory


@pytest.mark.parametrize(
    ("file_params", "names"),
    [
        (frozenset({"plan"}), {"plan"}),
        (["plan", "map"], {"plan", "map"}),
        ("plan", {"plan"}),
        ((), set()),
    ],
    ids=["set", "list", "text", "none"],
)
def test_file_params_are_the_names_its_author_meant(
    monkeypatch: pytest.MonkeyPatch, file_params: Any, names: set[str]
) -> None:
    monkeypatch.setattr(registry, "_registered", lambda: {"planner": _Entry(_factory(file_params))})
    assert registry.navigator_file_params("planner") == names


@pytest.mark.parametrize(
    ("file_params", "shown"), [(5, "5"), ([b"plan"], "[b'plan']")], ids=["number", "bytes"]
)
def test_file_params_that_name_no_parameter_are_refused_in_one_line(
    monkeypatch: pytest.MonkeyPatch, file_params: Any, shown: str
) -> None:
    monkeypatch.setattr(registry, "_registered", lambda: {"planner": _Entry(_factory(file_params))})
    with pytest.raises(InputError) as caught:
        registry.navigator_file_params("planner")
    assert str(caught.value) == (
        f"navigator 'planner': file_params: give the names of the parameters that name a"
        f" file (file_params = frozenset({{'plan'}})), not {shown}"
    )
