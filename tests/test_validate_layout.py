"""``pirate-bt validate`` refuses a robot description whose frames cannot fit the wire.

Every run refuses it at connect (``LayoutTooLarge``, exit 2); ``validate`` said "ok"
before, so a description grown past the protocol's largest frame passed its check and
failed only when run.
"""

from __future__ import annotations

import copy
from pathlib import Path

import pytest
import yaml

from pirate_bt.cli import main
from pirate_bt.errors import ValidationFailed
from pirate_bt.filekinds import validate_file
from pirate_bt.robot.loader import default_robot_path


def _grown(tmp_path: Path, extra_boards: int) -> Path:
    """The bundled robot with ``extra_boards`` more camera boards (two motors, two
    angle sensors each)."""
    data = yaml.safe_load(default_robot_path().read_text(encoding="utf-8"))
    camera = next(b for b in data["boards"] if b["id"] == 20)
    for i in range(extra_boards):
        board = copy.deepcopy(camera)
        board["id"] = 100 + i
        for part in (*board["motors"], *board["sensors"]):
            part["name"] = f"{part['name']}_{i}"
        data["boards"].append(board)
    path = tmp_path / "grown.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
    return path


def test_validate_names_a_state_frame_too_large_at_the_boards_key(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = _grown(tmp_path, 60)
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    line = next(n for n, text in enumerate(path.read_text().splitlines(), 1) if text == "boards:")
    assert err[0].startswith(f"{path}:{line}:1: robot 'PIRATE 2018': the robot description")
    assert "352-byte STATE payload (max 247)" in err[0]


def test_a_robot_that_still_fits_validates(tmp_path: Path) -> None:
    robot = validate_file(_grown(tmp_path, 5))
    assert len(robot.board_ids()) == 14
    with pytest.raises(ValidationFailed, match="does not fit the PIRATEbay protocol"):
        validate_file(_grown(tmp_path, 60), "hardware")
