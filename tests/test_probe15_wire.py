"""Probe 15 of the wire protocol: a clean-room host and bridge written from
docs/protocol.md alone, run against the simulated bridge and the pirate_bt host.

Each test pins one finding with its fix (docs/protocol.md, Layout).
"""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any

import pytest
import yaml

from pirate_bt.errors import ConfigurationError, ValidationFailed
from pirate_bt.link.codec import FrameCodec
from pirate_bt.link.layout import LayoutUncovered, WireLayout, layout_text, validate_robot_file
from pirate_bt.resources import default_robot_path
from pirate_bt.robot.loader import robot_from_data

DEFAULT: dict[str, Any] = yaml.safe_load(default_robot_path().read_text())


def _with_empty_board(board_id: int) -> dict[str, Any]:
    """The default robot plus a board that carries no motor and no sensor."""
    data = copy.deepcopy(DEFAULT)
    data["boards"].insert(0, {"id": board_id, "module": "front"})
    return data


def test_a_board_with_no_motor_and_no_sensor_is_refused_by_the_link() -> None:
    # The digest names boards only through their channels and motors: an empty board
    # 19 leaves it (and the channel and motor text) as the default robot's, yet takes
    # the first status nibble of STATE, so a host without it read board 20's status
    # from board 19's nibble (a bridge's FAULT on 19 came out as board 20 faulted).
    robot = robot_from_data(_with_empty_board(19))
    default = robot_from_data(DEFAULT)
    assert layout_text(robot) == layout_text(default)
    assert robot.layout_digest() == default.layout_digest()
    with pytest.raises(LayoutUncovered, match=r"board\(s\) 19 have no motor and no sensor"):
        WireLayout.from_robot(robot)
    with pytest.raises(ConfigurationError):  # exit 2, as a frame that does not fit
        FrameCodec.for_robot(robot)


def test_validate_reports_the_empty_board_at_boards(tmp_path: Path) -> None:
    path = tmp_path / "robot.yaml"
    path.write_text(yaml.safe_dump(_with_empty_board(29)))
    with pytest.raises(ValidationFailed, match=r"board\(s\) 29 have no motor and no sensor"):
        validate_robot_file(path)
