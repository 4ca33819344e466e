"""What the hostile-argument tests share: a refusal in one short line, and no hang."""

from __future__ import annotations

import re
import signal
from collections.abc import Callable, Iterator
from concurrent.futures import Executor, Future
from pathlib import Path
from typing import Any

import pytest

from pirate_bt.errors import InputError, PirateError


def refused(call: Callable[[], Any], *words: str, kind: type[PirateError] = InputError) -> str:
    """``call()`` raises ``kind`` with one short line holding every word; it is returned."""
    with pytest.raises(kind) as caught:
        call()
    text = str(caught.value)
    assert "\n" not in text, text
    # the length of what the message adds, whatever the length of pytest's temporary
    # folder in it (longer under xdist: .../pytest-386/popen-gw1/...)
    assert len(re.sub(r"\S*pytest-of-[^/\s]+/\S+", "<tmp>", text)) < 400, text
    for word in words:
        assert word in text, (word, text)
    return text


def no_hang(seconds: int = 20) -> Iterator[None]:
    """For an autouse fixture: a refusal that hangs instead fails the test after
    ``seconds`` (the hang was the bug)."""

    def fail(*_: Any) -> None:
        raise TimeoutError("hung: the argument was not refused")

    previous = signal.signal(signal.SIGALRM, fail)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)


class InstantExecutor(Executor):
    """Runs nothing: every case submitted is a success at once (a campaign's resume and
    refusal logic alone); ``ids`` lists the cases submitted, in order."""

    def __init__(self) -> None:
        self.ids: list[str] = []

    def submit(self, fn: Any, /, *args: Any, **kwargs: Any) -> Future[Any]:
        from pirate_bt.campaign.case import error_record

        case = args[0]
        self.ids.append(case["id"])
        future: Future[Any] = Future()
        future.set_result(error_record(case, "success", "done", 0.1))
        return future


def run_import_cli(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], data: str | bytes
) -> tuple[int, list[str]]:
    """``pirate-bt import btcpp`` of ``data`` (text as UTF-8, or bytes as they are) in
    ``tmp_path``: its exit code and stderr lines, after checking that it printed no
    traceback and wrote its output only on success."""
    from pirate_bt.cli import main

    source = tmp_path / "t.xml"
    source.write_bytes(data.encode("utf-8") if isinstance(data, str) else data)
    code = main(["import", "btcpp", str(source), "-o", str(tmp_path / "t.yaml")])
    captured = capsys.readouterr()
    assert "Traceback" not in captured.err and "internal error" not in captured.err
    assert sorted(p.name for p in tmp_path.iterdir()) == (
        ["t.xml"] if code else ["t.xml", "t.yaml"]
    )
    return code, captured.err.splitlines()
