"""A robot description's lookups by name or id name what the robot has when they
miss, so a planner script's typo says what it could have written."""

from __future__ import annotations

import pytest

from pirate_bt.robot import load_robot


@pytest.mark.parametrize(
    ("lookup", "words"),
    [
        (lambda r: r.module("bend_9"), ["module 'bend_9'", "bend_1", "rotational"]),
        (lambda r: r.motor("bend_1_jiont"), ["motor 'bend_1_jiont'", "bend_1_joint"]),
        (lambda r: r.board(99), ["board with id 99", "20"]),
        (lambda r: r.board_of("imu_x"), ["motor or sensor 'imu_x'", "imu", "bend_1_drive"]),
    ],
)
def test_a_missed_lookup_names_what_the_robot_has(lookup: object, words: list[str]) -> None:
    robot = load_robot()
    with pytest.raises(KeyError) as raised:
        lookup(robot)  # type: ignore[operator]
    message = str(raised.value.args[0])
    for word in words:
        assert word in message, message


def test_a_hit_still_gives_the_part() -> None:
    robot = load_robot()
    assert robot.module("bend_1").name == "bend_1"
    assert robot.motor("bend_1_joint").name == "bend_1_joint"
    assert robot.board_of("imu") is robot.board_of("imu")


def test_a_value_whose_raw_value_overflows_saturates() -> None:
    # CommandCodec.to_raw(1e308 of PWM duty) raised OverflowError: value / per_raw is inf
    from pirate_bt.robot.commands import CommandCodec, MotorCommand
    from pirate_bt.robot.description import ControlMode

    codec = CommandCodec(load_robot())
    lo, hi = load_robot().motor("front_leds").modes.pwm.raw  # type: ignore[union-attr]
    for value, raw in ((1e308, hi), (-1e308, lo), (1e30, hi)):
        setpoint = codec.to_raw(MotorCommand("front_leds", ControlMode.PWM, value))
        assert setpoint.raw_value == raw, value
