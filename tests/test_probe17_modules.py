"""Probe 17 of the lower public modules, called with hostile but plausible arguments.

Each test is one thing a user of ``pirate_bt.pipes``, ``pirate_bt.sim`` and the
layers beside them saw: a traceback from inside the library, or a silent nonsense
answer, where one line naming the argument or the file's place was due.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.cli import main
from pirate_bt.errors import ValidationFailed
from pirate_bt.pipes import network_from_data


def _line(*extra: dict[str, str]) -> dict[str, object]:
    segments = [{"type": "straight", "length": "1 m"}, *extra]
    return {"name": "x", "diameter": "63 mm", "segments": segments}


@pytest.mark.parametrize(
    "segment",
    [
        {"type": "bend", "direction": "up", "angle": "1e-300 deg"},
        {"type": "straight", "length": "1e-300 m"},
        {"type": "reducer", "diameter": "55 mm", "length": "1e-300 m"},
    ],
)
def test_a_piece_too_short_to_have_a_length_is_refused(segment: dict[str, str]) -> None:
    """A bend of 1e-300 deg after 1 m of pipe ended `pirate-bt validate` (and
    `load_network`) in *internal error: ZeroDivisionError*: 1 m + 1e-302 m is 1 m, and
    the bend's end frame divided by its length 0. A straight or reducer as short passed
    validate as a piece with no length."""
    with pytest.raises(ValidationFailed) as caught:
        network_from_data(_line(segment), "f.yaml")
    message = str(caught.value)
    assert "segment 'main-2' has no length 1 m along its line" in message
    assert len(caught.value.errors) == 1


def test_validate_says_where_a_bend_has_no_length(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "tiny.yaml"
    path.write_text(
        "name: x\ndiameter: 63 mm\nsegments:\n  - {type: straight, length: 1 m}\n"
        "  - {type: bend, direction: up, angle: 1e-300 deg}\n"
    )
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr().err
    assert f"{path}:5:33: segment 'main-2' has no length" in err
    assert "internal error" not in err
