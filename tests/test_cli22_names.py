"""A file name typed with a control character in it is named in one line, escaped, as
the file checks name one (``a\\nb.yaml:1:1: no such file``)."""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.cli import main


@pytest.mark.parametrize(
    ("argv", "said"),
    [
        (["trace", "summary", "{x}.jsonl"], "{x}.jsonl: cannot read trace: No such file or"),
        (["export", "btcpp", "straight", "-o", "{x}.txt"], "{x}.txt: BehaviorTree.CPP XML is"),
        (
            ["run", "straight", "--param", "distance=0.1m", "--trace={x}.txt"],
            "{x}.txt: unknown trace format",
        ),
    ],
    ids=["trace summary", "export -o", "run --trace="],
)
def test_a_file_name_with_a_newline_is_one_line_of_error(
    argv: list[str], said: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Before: each message was cut at the newline into two lines, 'pirate-bt: .../a'
    and 'pirate-bt: b.jsonl: cannot read trace: ...'."""
    raw = f"{tmp_path}/a\nb"
    assert main([a.replace("{x}", raw) for a in argv]) == 2
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 1, lines
    assert lines[0].startswith("pirate-bt: " + said.replace("{x}", f"{tmp_path}/a\\nb"))


def test_a_file_written_with_a_newline_in_its_name_is_said_on_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Before: 'drew .../a' and 'b.dot' on two lines of standard output."""
    out = tmp_path / "a\nb.dot"
    assert main(["render", "straight", "-o", str(out)]) == 0
    assert out.is_file()
    assert capsys.readouterr().out.splitlines() == [f"drew {tmp_path}/a\\nb.dot"]
