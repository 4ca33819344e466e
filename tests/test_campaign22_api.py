"""Session 22: run_campaign's callbacks are refused before any case runs when they
cannot be called as the campaign calls them."""

from __future__ import annotations

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


async def _async_record(row: dict[str, Any]) -> None:  # called, never awaited
    del row


class _Recorder:
    def __call__(self, first: Any, second: Any) -> None:  # one argument too many
        del first, second


@pytest.mark.parametrize(
    ("option", "value", "words"),
    [
        ("on_record", lambda: None, "cannot be called as on_record(row)"),
        ("on_record", lambda row, extra: None, "cannot be called as on_record(row)"),
        ("on_record", _Recorder(), "cannot be called as on_record(row)"),
        ("on_record", _async_record, "is an async def"),
        ("echo", lambda: None, "cannot be called as echo(line)"),
    ],
    ids=["no-argument", "two-arguments", "object", "async", "echo"],
)
def test_a_callback_the_campaign_cannot_call_is_refused_before_any_case_runs(
    tmp_path: Path, option: str, value: Any, words: str
) -> None:
    out = tmp_path / "out"
    # was a bare TypeError ("<lambda>() takes 0 positional arguments but 1 was given")
    # raised from deep inside once the first case had run and its row was written
    with pytest.raises(ArgumentTypeError) as caught:
        run_campaign(SPEC, workers=1, output=out, **{option: value})
    message = str(caught.value)
    assert message.startswith(f"{option}: ") and words in message
    assert len(message.splitlines()) == 1
    assert not out.exists()  # nothing ran, nothing was written


def test_callbacks_the_campaign_can_call_are_taken(tmp_path: Path) -> None:
    seen: list[str] = []
    lines: list[str] = []

    def record(row: dict[str, Any], *rest: Any, extra: int = 0) -> None:
        seen.append(row["id"])

    result = run_campaign(SPEC, workers=1, on_record=record, echo=lines.append)
    assert [r["id"] for r in result.rows] == seen and len(seen) == 1
    assert len(lines) == 1 and lines[0].startswith("campaign callbacks: 1 cases")
