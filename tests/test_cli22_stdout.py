"""A command whose output is the text it prints (a schema, a trace's tick or summary,
the robot's board table) is refused in one line, exit 2, when standard output was
closed (``>&-``), as ``-o -`` is: the text went to the null device that stands in for
the closed stream, and the command exited 0 having shown nothing anywhere."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from pirate_bt.cli import main


@pytest.mark.parametrize(
    ("argv", "what"),
    [
        (["schema", "tree"], "the schema"),
        (["trace", "schema"], "the schema"),
        (["trace", "summary", "{trace}"], "the summary"),
        (["trace", "show", "{trace}"], "the tick"),
        (["robot"], "the board table"),
    ],
)
def test_text_for_a_closed_standard_output_is_refused(
    argv: list[str],
    what: str,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    trace = tmp_path / "t.jsonl"
    if "{trace}" in argv:
        assert main(["run", "straight", "--param", "distance=0.02m", "--trace", str(trace)]) == 0
        capsys.readouterr()
    monkeypatch.setattr(sys, "stdout", None)  # as Python sets it for a closed descriptor 1
    assert main([a.replace("{trace}", str(trace)) for a in argv]) == 2
    assert capsys.readouterr().err.splitlines() == [
        f"pirate-bt: standard output is closed; {what} not written"
    ]


def test_the_board_table_with_a_drawing_is_no_output_of_its_own(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """``robot --draw OUT`` writes the drawing: a closed standard output loses only the
    table shown beside it."""
    monkeypatch.setattr(sys, "stdout", None)
    assert main(["robot", "--draw", str(tmp_path / "r.dot")]) == 0
    assert (tmp_path / "r.dot").is_file()
