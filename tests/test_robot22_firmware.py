"""Robot descriptions that validated but could not work on the reference firmware.

Each test edits a copy of hardware/pirate.yaml as a lab describing its robot might,
and checks that ``pirate-bt validate`` refuses it in one line at the key to change,
where before the simulator drove it and the reference PICO boards did not.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.cli import main
from pirate_bt.errors import ValidationFailed
from pirate_bt.robot import load_robot

GOOD = (Path(__file__).resolve().parent.parent / "hardware" / "pirate.yaml").read_text()


def variant(tmp_path: Path, *edits: tuple[str, str]) -> Path:
    """A copy of the bundled robot with every ``old`` replaced by ``new``."""
    text = GOOD
    for old, new in edits:
        assert old in text, old
        text = text.replace(old, new)
    path = tmp_path / "my-robot.yaml"
    path.write_text(text, encoding="utf-8")
    return path


def line_of(path: Path, anchor: str) -> int:
    lines = [i for i, line in enumerate(path.read_text().splitlines(), 1) if anchor in line]
    assert len(lines) == 1, (anchor, lines)
    return lines[0]


def validate(path: Path, capsys: pytest.CaptureFixture[str]) -> tuple[int, list[str]]:
    code = main(["validate", str(path)])
    out = capsys.readouterr()
    return code, (out.out + out.err).splitlines()


# A bridge sending a state frame every 150 ms, its sensors and silence limits made to
# fit (before, this validated: the PICO boards stop themselves after 100 ms without a
# poll, so every reply said OWN_STOP and the bridge stopped the robot every cycle).
SLOW_BRIDGE = (
    ("state_period: 10 ms", "state_period: 150 ms"),
    ("    period: 10 ms", "    period: 50 ms"),  # every sensor's
    ("watchdog: 250 ms", "watchdog: 500 ms"),
    ("max_link_silence: 500 ms", "max_link_silence: 1 s"),
)


def test_a_state_period_the_boards_time_out_in_is_refused_at_its_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = variant(tmp_path, *SLOW_BRIDGE)
    code, lines = validate(path, capsys)
    assert code == 2
    assert len(lines) == 1, lines
    line = line_of(path, "state_period: 150 ms")
    assert lines[0].startswith(f"{path}:{line}:3: a state period of 150 ms is too long"), lines
    assert "a PICO board stops itself after 100 ms without a poll" in lines[0]
    assert "make it at most 50 ms" in lines[0]
    with pytest.raises(ValidationFailed, match="state period of 150 ms is too long"):
        load_robot(path)


@pytest.mark.parametrize("period", ["50 ms", "20 ms"])
def test_a_state_period_of_half_the_boards_silence_time_or_less_validates(
    tmp_path: Path, period: str
) -> None:
    robot = load_robot(variant(tmp_path, ("state_period: 10 ms", f"state_period: {period}")))
    assert robot.bridge.state_period <= 0.05


def test_a_position_mode_without_an_angle_sensor_on_its_slot_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # before, this validated: the reference PICO braked camera_pan on every position
    # setpoint (it has no angle channel to close the loop on), the simulator moved it
    path = variant(tmp_path, ("      - {<<: *angle_sensor, slot: 1, name: camera_pan_angle}\n", ""))
    code, lines = validate(path, capsys)
    assert code == 2
    assert len(lines) == 1, lines
    text = path.read_text().splitlines()
    pan = next(i for i, line in enumerate(text) if "name: camera_pan" in line)
    line = next(i for i in range(pan, len(text)) if "position:" in text[i]) + 1
    assert lines[0].startswith(f"{path}:{line}:"), lines
    assert (
        "motor 'camera_pan' (board 20, slot 1) has a position mode, but its board has no"
        " angle sensor on slot 1" in lines[0]
    )
    assert "brakes the motor on every position setpoint" in lines[0]


def test_a_sensor_of_another_kind_on_the_slot_does_not_close_a_position_loop(
    tmp_path: Path,
) -> None:
    path = variant(
        tmp_path,
        (
            "      - {<<: *angle_sensor, slot: 1, name: camera_pan_angle}\n",
            "      - {<<: *spring_sensor, slot: 1, name: camera_pan_spring}\n",
        ),
    )
    with pytest.raises(ValidationFailed, match=r"'camera_pan' .* no angle sensor on slot 1"):
        load_robot(path)


def test_a_motor_without_a_position_mode_needs_no_angle_sensor(tmp_path: Path) -> None:
    path = variant(
        tmp_path,
        ("      - {<<: *angle_sensor, slot: 1, name: camera_pan_angle}\n", ""),
        (
            "        name: camera_pan\n        function: camera_pan\n        modes:\n"
            "          pwm: {raw: [-255, 255], per_raw: 0.392156862745098 %}\n"
            "          position: {raw: [-2048, 2047], per_raw: 0.087890625 deg}\n"
            "        limits:\n          angle: {min: -90 deg, max: 90 deg, policy: clip}\n",
            "        name: camera_pan\n        function: camera_pan\n        modes:\n"
            "          pwm: {raw: [-255, 255], per_raw: 0.392156862745098 %}\n",
        ),
    )
    robot = load_robot(path)
    assert robot.motor("camera_pan").modes.position is None


FRONT_LEDS = (
    "      - slot: 1\n        name: front_leds\n        function: leds\n        modes:\n"
    "          pwm: {raw: [0, 255], per_raw: 0.392156862745098 %}\n"
)
DRIVE_FEEDBACK = (
    "    feedback:\n      velocity: {raw: [-1200, 1200], per_raw: 0.1 mm/s}\n"
    "      current: {raw: [0, 1023], per_raw: 4 mA}\n"
)


@pytest.mark.parametrize(
    ("edit", "words"),
    [
        # a drive on the front module, which has no wheels: the PICO's speed scale is 0
        (
            (FRONT_LEDS, "      - {<<: *drive_motor, slot: 1, name: front_drive}\n"),
            "motor 'front_drive' has a velocity mode, but its module 'front' has no wheel_radius",
        ),
        # drives that report no speed: the PICO's speed scale is 0 too
        (
            (DRIVE_FEEDBACK, "    feedback:\n      current: {raw: [0, 1023], per_raw: 4 mA}\n"),
            "motor 'bend_1_drive' has a velocity mode, but it has no velocity feedback",
        ),
    ],
)
def test_a_velocity_mode_the_board_cannot_close_its_loop_on_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], edit: tuple[str, str], words: str
) -> None:
    # before, the first validated and the simulator drove the wheel at the speed asked,
    # while the reference PICO read a speed of 0 and its loop wound up to full duty
    path = variant(tmp_path, edit)
    code, lines = validate(path, capsys)
    assert code == 2
    assert words in lines[0], lines
    assert "drives at full duty whatever speed is asked" in lines[0]
    # the velocity mode, in the drive_motor template every drive takes its modes from
    anchor = "      velocity: {raw: [-1200, 1200]"
    line = next(i for i, text in enumerate(path.read_text().splitlines(), 1) if anchor in text)
    assert lines[0].startswith(f"{path}:{line}:"), lines


def test_a_watchdog_its_line_cannot_keep_fed_is_refused_at_its_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # before, this validated, and every run was refused at the handshake, to the
    # simulator as to the bridge: "the bridge's watchdog is 150 ms, shorter than its line
    # can keep fed (...); a firmware built for another robot description?"
    path = variant(
        tmp_path, ("baud: 115200", "baud: 9600"), ("watchdog: 250 ms", "watchdog: 150 ms")
    )
    code, lines = validate(path, capsys)
    assert code == 2
    assert lines == [
        f"{path}:{line_of(path, 'watchdog: 150 ms')}:3: watchdog 150 ms is too short for its"
        " line at 9600 baud: the host sends ten heartbeats a watchdog period, each 9.38 ms"
        " on the line, and they may take at most half of it, so the watchdog must be at"
        " least 188 ms (docs/protocol.md, Heartbeats); lengthen it (and"
        " safety.max_link_silence with it) or raise the baud"
    ]
    fixed = variant(
        tmp_path, ("baud: 115200", "baud: 9600"), ("watchdog: 250 ms", "watchdog: 188 ms")
    )
    assert load_robot(fixed).bridge.watchdog == pytest.approx(0.188)


def test_the_heartbeat_s_size_is_the_link_s() -> None:
    from pirate_bt.link import hellos
    from pirate_bt.robot.firmware_fit import HEARTBEAT_WIRE_BYTES

    assert hellos._HEARTBEAT_FRAME_BYTES == HEARTBEAT_WIRE_BYTES


def test_a_line_too_slow_for_a_fresh_state_frame_is_refused_at_the_baud(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # before, this validated and the simulator (which has no line) ran every tree; a
    # bridge at 4800 baud can send a 76-byte STATE only every 158 ms, and every reading
    # counts as stale after 100 ms
    path = variant(
        tmp_path, ("baud: 115200", "baud: 4800"), ("watchdog: 250 ms", "watchdog: 400 ms")
    )
    code, lines = validate(path, capsys)
    assert code == 2
    assert lines == [
        f"{path}:{line_of(path, 'baud: 4800')}:3: a STATE frame of 76 bytes takes 158.3 ms at"
        " 4800 baud, so the bridge can send one only that often, and readings of"
        " 'camera_tilt_angle' count as stale after 100 ms (safety.stale_after_periods x its"
        " period): every run on the bridge would stop on stale data; raise the baud"
    ]
    # 9600 baud: a STATE every 79 ms, fresher than the 100 ms the readings allow
    slower = variant(tmp_path, ("baud: 115200", "baud: 9600"))
    assert load_robot(slower).bridge.baud == 9600


@pytest.mark.parametrize(
    "name", ["pirate.yaml", "variants/pirate-long.yaml", "variants/pirate-rear-imu.yaml"]
)
def test_the_state_frame_s_size_is_the_link_s(name: str) -> None:
    from pirate_bt.link.layout import WireLayout
    from pirate_bt.robot.firmware_fit import state_wire_bytes

    robot = load_robot(Path(__file__).resolve().parent.parent / "hardware" / name)
    layout = WireLayout.from_robot(robot)
    assert state_wire_bytes(robot) == layout.wire_bytes(layout.state_payload_bytes)
