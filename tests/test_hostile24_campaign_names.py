"""A campaign's names and labels as the report and a terminal show them.

A spec refused C0 control characters and DEL, but took U+009B (a C1 control: ESC [
to many terminals) and a text-direction override or a zero-width space in its name
and its runs' names, which the report and the log print. Each is refused at its key.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.cli import main


@pytest.mark.parametrize(
    ("name", "words"),
    [
        (r'"a\x9bb"', "control characters (NUL, newline, tab, ...) are not allowed here"),
        (
            r'"a\u202eb"',
            "U+202E RIGHT-TO-LEFT OVERRIDE (an invisible character) is not allowed here",
        ),
        (r'"a\u200bb"', "U+200B ZERO WIDTH SPACE (an invisible character) is not allowed here"),
    ],
)
@pytest.mark.parametrize("where", ["campaign", "run"])
def test_a_hidden_character_in_a_name_is_refused_at_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], name: str, words: str, where: str
) -> None:
    campaign, run = (name, "t") if where == "campaign" else ("c", name)
    spec = tmp_path / "c.campaign.yaml"
    spec.write_text(f"name: {campaign}\nruns:\n  - {{name: {run}, route: t-joint.route}}\n")
    assert main(["validate", str(spec)]) == 2
    place = "1:1" if where == "campaign" else "3:6"
    assert capsys.readouterr().err == f"{spec}:{place}: {words}\n"
