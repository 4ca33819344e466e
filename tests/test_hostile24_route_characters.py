"""Characters a terminal would not show as they are, in a route.

A route's control character was echoed raw in its error (*unknown unit 'm<ESC>[31m'*,
*unknown command 'for<ESC>[2Jward'*): a route file could recolour or clear the
terminal of the operator who validated it, and a zero-width space made *forward 1 m*
an unknown unit shown as *m*. Each is now refused at its line and column, named.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.cli import main
from pirate_bt.errors import ValidationFailed
from pirate_bt.task import parse_route


@pytest.mark.parametrize(
    ("line", "column", "named"),
    [
        ("forward 1 m\x1b[31m", 12, "U+001B"),
        ("for\x1b[2Jward 1 m", 4, "U+001B"),
        ("at the T\x07-joint go left", 9, "U+0007"),
        ("forward 1\u200b m", 10, "U+200B ZERO WIDTH SPACE"),
        ("forward 1 m \u202e", 13, "U+202E RIGHT-TO-LEFT OVERRIDE"),
        ("forward 1 m  # a bell in a comment \x07", 36, "U+0007"),
    ],
)
def test_a_hidden_character_is_refused_where_it_is_never_echoed(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], line: str, column: int, named: str
) -> None:
    path = tmp_path / "r.route"
    path.write_text(f"network straight\n{line}\n", encoding="utf-8")
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.isascii() and err.count("\n") == 1, err
    assert err.startswith(f"{path}:2:{column}: {named} ")
    assert "is not allowed in a route" in err
    assert "\x1b" not in err and "\x07" not in err


def test_parse_route_refuses_the_same_and_takes_tabs_and_comments() -> None:
    with pytest.raises(ValidationFailed) as caught:
        parse_route("network straight\nforward 1 m\x1b[2J\n", "r.route")
    assert str(caught.value.errors[0]).startswith("r.route:2:12: U+001B")
    route = parse_route(
        "network straight\nforward\t1 m  # \u202e a comment may say anything visible\n"
    )
    assert [step.text for step in route.steps] == ["forward 1 m"]
