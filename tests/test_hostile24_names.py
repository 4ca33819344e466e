"""A robot's and a network's name as a terminal shows it.

A robot description named ``"a\\x07\\x1b[31mb"`` validated, and ``pirate-bt robot``
printed its name raw: the file rang the bell and recoloured (or, with ``\\x1b[2J``,
cleared) the operator's terminal; a network's name could hold a newline or a
text-direction override. A tree's name has long refused them; now these do too, at
the name, exit 2.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.cli import main

_ROOT = Path(__file__).resolve().parents[1]
_FILES = {
    "robot": (_ROOT / "hardware" / "pirate.yaml", "name: PIRATE 2018", 8),
    "network": (_ROOT / "scenarios" / "straight.yaml", "name: straight", 4),
}


@pytest.mark.parametrize("kind", sorted(_FILES))
@pytest.mark.parametrize(
    ("written", "named"),
    [
        (r'"a\x07\x1b[31mb"', r"U+0007 \x07 (a control character)"),
        (r'"two\nlines"', r"U+000A \n (a control character)"),
        (r'"a\u202eb"', "U+202E RIGHT-TO-LEFT OVERRIDE (an invisible character)"),
    ],
)
def test_a_name_a_terminal_would_not_show_as_written_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], kind: str, written: str, named: str
) -> None:
    source, line, line_no = _FILES[kind]
    text = source.read_text(encoding="utf-8")
    assert line in text
    path = tmp_path / "file.yaml"
    path.write_text(text.replace(line, f"name: {written}", 1), encoding="utf-8")
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr().err
    assert err == f"{path}:{line_no}:1: name: must not contain {named}\n"


def test_the_robot_table_of_a_plain_name_still_prints(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["robot", "--robot", str(_ROOT / "hardware" / "pirate.yaml")]) == 0
    assert capsys.readouterr().out.startswith("PIRATE 2018: ")
