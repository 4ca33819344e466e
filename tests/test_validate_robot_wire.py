"""``pirate-bt validate`` refuses a robot description too large for the protocol's
frames, as ``run`` does when it connects (it said "ok" and the run then failed)."""

from __future__ import annotations

import copy
from pathlib import Path

import pytest
import yaml

from pirate_bt.cli import main
from pirate_bt.resources import default_robot_path


def _robot_with_boards(tmp_path: Path, n: int) -> Path:
    robot = yaml.safe_load(default_robot_path().read_text(encoding="utf-8"))
    first = robot["boards"][0]
    for i in range(n - len(robot["boards"])):
        board = copy.deepcopy(first)
        board["id"] = 40 + i
        for part in (*board["motors"], *board.get("sensors", [])):
            part["name"] = f"{part['name']}_{i}"
        robot["boards"].append(board)
    path = tmp_path / f"robot{n}.yaml"
    path.write_text(yaml.safe_dump(robot), encoding="utf-8")
    return path


def test_validate_refuses_a_robot_whose_frames_do_not_fit(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = _robot_with_boards(tmp_path, 18)
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"{path}: robot ")
    assert "18 boards need a 254-byte COUNTERS payload (max 247: 17 boards)" in err
    assert len(err.splitlines()) == 1


def test_validate_takes_a_larger_robot_that_fits(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = _robot_with_boards(tmp_path, 12)
    assert main(["validate", str(path)]) == 0, capsys.readouterr().err
