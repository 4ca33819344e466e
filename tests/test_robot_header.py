"""``pirate-bt robot header``: the robot description as the firmware's C layout header."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
import yaml

from pirate_bt.cli import main
from pirate_bt.errors import ConfigurationError
from pirate_bt.robot.description import ControlMode
from pirate_bt.robot.header import MODE_ORDER, STOP_ROLES, board_slices, render_header, stop_role
from pirate_bt.robot.loader import load_robot, robot_from_data

ROOT = Path(__file__).resolve().parents[1]
ROBOTS = [
    ROOT / "hardware" / "pirate.yaml",
    *sorted((ROOT / "hardware" / "variants").glob("*.yaml")),
]


def _define(text: str, name: str) -> str:
    match = re.search(rf"^#define {name} (.+)$", text, re.MULTILINE)
    assert match, name
    return match.group(1)


def _table(text: str, name: str) -> list[list[int]]:
    block = text.split(f"#define {name} {{ \\\n", 1)[1].split("\n}", 1)[0]
    rows = []
    for line in block.splitlines():
        line = re.sub(r"/\*.*?\*/", "", line)
        line = line.replace("PB_ROLE_", "").rstrip(" \\,")
        for role, code in zip(STOP_ROLES, range(4), strict=True):
            line = re.sub(rf"\b{role.upper()}\b", str(code), line)
        rows.append([int(x, 0) for x in re.findall(r"-?0x[0-9A-F]+|-?\d+", line)])
    return rows


@pytest.mark.parametrize("path", ROBOTS, ids=lambda p: p.stem)
def test_header_matches_the_robot_descriptions_wire_layout(path: Path) -> None:
    robot = load_robot(path)
    text = render_header(robot, str(path))
    channels, motors, boards = robot.state_channels(), robot.setpoint_slots(), robot.board_ids()
    assert _define(text, "PB_LAYOUT_DIGEST") == f"0x{robot.layout_digest():08X}UL"
    assert int(_define(text, "PB_N_CHANNELS")) == len(channels)
    assert int(_define(text, "PB_N_MOTORS")) == len(motors)
    assert int(_define(text, "PB_N_BOARDS")) == len(boards)
    assert int(_define(text, "PB_WATCHDOG_MS")) == round(robot.bridge.watchdog * 1000)
    assert int(_define(text, "PB_STATE_PERIOD_MS")) == round(robot.bridge.state_period * 1000)
    assert _define(text, "PB_BAUD") == f"{robot.bridge.baud}UL"
    # boards: ascending ids, each owning exactly its channels and motors
    rows = _table(text, "PB_BOARD_TABLE")
    assert [r[0] for r in rows] == boards
    for board_id, first_ch, n_ch, first_m, n_m, mask in rows:
        assert [c.index for c in channels if c.board == board_id] == list(
            range(first_ch, first_ch + n_ch)
        )
        mine = [m for m in motors if m.board == board_id]
        assert [m.index for m in mine] == list(range(first_m, first_m + n_m))
        assert mask == sum(1 << m.slot for m in mine)
    # motors: role and the raw range of every accepted mode, none of the others
    for slot, row in zip(motors, _table(text, "PB_MOTOR_TABLE"), strict=True):
        board_index, motor_slot, role, mask, *ranges = row
        assert boards[board_index] == slot.board and motor_slot == slot.slot
        assert STOP_ROLES[role] == stop_role(slot.motor.function)
        for code, mode in enumerate(MODE_ORDER):
            conv = slot.motor.modes.get(mode)
            lo, hi = ranges[2 * code : 2 * code + 2]
            if conv is None:
                assert not mask >> code & 1 and lo > hi
            else:
                assert mask >> code & 1 and (lo, hi) == tuple(conv.raw)


def test_stop_roles_follow_the_motor_function() -> None:
    robot = load_robot()
    roles = {m.motor.name: stop_role(m.motor.function) for m in robot.setpoint_slots()}
    assert roles["bend_1_joint"] == "bend" and roles["rotate"] == "rotate"
    assert roles["bend_1_drive"] == "drive" and roles["front_tilt"] == "other"
    assert roles["camera_pan"] == "other" and roles["rear_leds"] == "other"


def test_board_slices_cover_a_board_without_motors_or_sensors() -> None:
    data = yaml.safe_load(ROBOTS[0].read_text())
    data["boards"].append({"id": 99, "module": "rear"})
    slices = board_slices(robot_from_data(data))
    last = slices[-1]
    assert last.board == 99 and last.channels == () and last.motor_slots == ()
    # but no header is written for it: the layout digest cannot cover such a board, so
    # the host refuses the robot (pirate_bt.link.layout) and the firmware must not
    # be built for it either (tests/test_probe15_wire.py)
    with pytest.raises(ConfigurationError, match="have no motor and no sensor"):
        render_header(robot_from_data(data))


def test_cli_writes_the_header_atomically(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "build" / "layout.h"
    assert main(["robot", "header", str(ROBOTS[0]), "-o", str(out)]) == 0
    assert out.read_text() == render_header(load_robot(ROBOTS[0]), str(ROBOTS[0]))
    assert [p.name for p in out.parent.iterdir()] == ["layout.h"]  # no temporary left
    assert main(["robot", "header"]) == 0
    assert "#define PB_N_MOTORS 16" in capsys.readouterr().out


def test_cli_refuses_a_bad_description_without_writing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text(ROBOTS[0].read_text().replace("baud: 115200", "baud: fast"))
    out = tmp_path / "layout.h"
    assert main(["robot", "header", str(bad), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert "bad.yaml:" in err and "baud" in err
    assert not out.exists()


def test_every_mode_code_is_in_the_header_order() -> None:
    assert list(MODE_ORDER) == [
        ControlMode.PWM,
        ControlMode.TORQUE,
        ControlMode.POSITION,
        ControlMode.VELOCITY,
    ]
