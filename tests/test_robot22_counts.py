"""A robot description with more boards than the bus has addresses is refused in one line.

Board ids run from 1 to 254, each once, so a list of 3,000 boards (a generated file, a
loop gone wrong) can only repeat them: it was refused with one line per repeated id
(2,800 lines), now with one at the list.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.cli import main

GOOD = (Path(__file__).resolve().parent.parent / "hardware" / "pirate.yaml").read_text()


def test_more_boards_than_bus_addresses_are_refused_in_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    boards = "".join(
        f"  - id: {29 + i % 200}\n    module: rear\n    sensors:\n"
        f"      - {{<<: *angle_sensor, slot: 0, name: extra_{i}}}\n"
        for i in range(600)
    )
    path = tmp_path / "many.yaml"
    path.write_text(GOOD.replace("\nclamp:", "\n" + boards + "\nclamp:"), encoding="utf-8")
    code = main(["validate", str(path)])
    lines = capsys.readouterr().err.splitlines()
    assert code == 2
    line = next(i for i, text in enumerate(GOOD.splitlines(), 1) if text == "boards:")
    assert lines == [f"{path}:{line}:1: boards: must have at most 254 items, not 609"]
