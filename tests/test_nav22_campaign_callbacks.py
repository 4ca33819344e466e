"""Session 22: run_campaign's ``on_record`` or ``echo`` with a ``yield`` in it (a
generator function, whose body never runs when it is called) passed zero rows with no
word; it is refused before any case runs, as an ``async def`` is (docs/api.md)."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from pirate_bt.campaign import run_campaign
from pirate_bt.errors import ArgumentTypeError

SPEC = {
    "name": "callbacks",
    "runs": [
        {"name": "s", "tree": "straight", "network": "straight", "params": {"distance": "0.1 m"}}
    ],
    "max_time": "60 s",
    "case_timeout": "120 s",
}

seen: list[Any] = []


def gen_record(row: dict[str, Any]) -> Iterator[None]:
    seen.append(row)  # never runs: calling it only makes a generator
    yield


async def agen_echo(line: str) -> Any:
    seen.append(line)
    yield


class _YieldingRecorder:
    def __call__(self, row: dict[str, Any]) -> Iterator[None]:
        seen.append(row)
        yield


@pytest.mark.parametrize(
    ("option", "value", "label", "what"),
    [
        ("on_record", gen_record, "gen_record", "a generator function (it yields)"),
        ("on_record", _YieldingRecorder(), "_YieldingRecorder", "a generator function (it yields)"),
        ("echo", gen_record, "gen_record", "a generator function (it yields)"),
        ("echo", agen_echo, "agen_echo", "an async def"),
    ],
    ids=["on_record", "callable-object", "echo", "echo-async-generator"],
)
def test_a_callback_that_yields_is_refused_before_any_case_runs(
    tmp_path: Path, option: str, value: Any, label: str, what: str
) -> None:
    out = tmp_path / "out"
    argument = "row" if option == "on_record" else "line"
    with pytest.raises(ArgumentTypeError) as caught:
        run_campaign(SPEC, workers=1, output=out, **{option: value})
    assert str(caught.value) == (
        f"{option}: {label} is {what}, which {option}({argument}) would call and never run;"
        " give a plain function"
    )
    assert not out.exists()  # nothing ran, nothing was written
    assert seen == []
