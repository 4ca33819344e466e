"""Odometry counts the wheels whose speed is fresh.

A wheel speed sensor that drops out keeps its last value in the state (its fresh
bit clear). The drive and the localiser used to average it in: a wheel stuck at the
0 m/s it read before the drive started made a 0.5 m drive go a fifth further
(207 ticks instead of 182). A sensor stuck at a value it keeps *fresh* cannot be
told by its freshness: odometry cross-checks the wheels instead (every drive motor
is commanded the same speed), and leaves out one that disagrees with the majority.
"""

from __future__ import annotations

from pathlib import Path

import pytest

import pirate_bt
from pirate_bt.robot import load_robot
from pirate_bt.robot.state import Reading, RobotState, wheel_fresh_window_s

STRAIGHT = Path(__file__).parents[1] / "trees" / "straight.yaml"
WHEELS = ("bend_1_drive", "bend_2_drive", "bend_3_drive", "bend_4_drive")


def state(stamps: dict[str, float], speeds: dict[str, float], now: float = 10.0) -> RobotState:
    return RobotState(
        stamp_s=now,
        readings={f"{m}.velocity": Reading(speeds[m], stamps[m]) for m in WHEELS},
        drive_velocity_mps=speeds,
    )


def test_a_stale_wheel_is_left_out_of_the_mean() -> None:
    speeds = {"bend_1_drive": 0.0, "bend_2_drive": 0.08, "bend_3_drive": 0.08, "bend_4_drive": 0.08}
    fresh = dict.fromkeys(WHEELS, 10.0)
    s = state({**fresh, "bend_1_drive": 8.0}, speeds)
    assert s.mean_drive_velocity_mps() == pytest.approx(0.06)  # every wheel, as before
    assert s.mean_drive_velocity_mps(9.9) == pytest.approx(0.08)  # the fresh ones
    assert state(dict.fromkeys(WHEELS, 8.0), speeds).mean_drive_velocity_mps(9.9) == 0.0
    # all fresh: the odd wheel out is left out of odometry's mean, not of the plain one
    assert state(fresh, speeds).mean_drive_velocity_mps(9.9) == pytest.approx(0.08)
    assert state(fresh, speeds).mean_drive_velocity_mps() == pytest.approx(0.06)


@pytest.mark.parametrize(
    ("speeds", "expected"),
    [
        ((0.0, 0.08, 0.08, 0.08), 0.08),  # stuck at 0 while the others drive
        ((0.08, 0.0, 0.0, 0.0), 0.0),  # stuck at the drive's speed after a stop
        ((0.08, 0.0802, 0.0798, 0.0805), 0.080125),  # noise: every wheel counts
        ((0.0, 0.0, 0.08, 0.08), 0.04),  # two against two: no majority, all count
        ((0.0, 0.08, 0.16, 0.08), 0.08),  # two odd ones out of four
        ((-0.08, -0.08, -0.03, -0.08), -0.08),  # backwards, 25 % of the median is 20 mm/s
        ((-0.08, -0.08, -0.065, -0.08), -0.07625),  # within the band: counts
    ],
)
def test_odometry_leaves_out_a_wheel_that_disagrees(
    speeds: tuple[float, ...], expected: float
) -> None:
    s = state(dict.fromkeys(WHEELS, 10.0), dict(zip(WHEELS, speeds, strict=True)))
    assert s.mean_drive_velocity_mps(9.9) == pytest.approx(expected)


def test_two_fresh_wheels_cannot_outvote_each_other() -> None:
    speeds = {"bend_1_drive": 0.0, "bend_2_drive": 0.08, "bend_3_drive": 0.08, "bend_4_drive": 0.0}
    stamps = {"bend_1_drive": 10.0, "bend_2_drive": 10.0, "bend_3_drive": 8.0, "bend_4_drive": 8.0}
    assert state(stamps, speeds).mean_drive_velocity_mps(9.9) == pytest.approx(0.04)


def test_the_window_is_the_supervisors_freshness_rule() -> None:
    robot = load_robot()
    periods = robot.channel_periods_s()
    slowest = max(periods[f"{m}.velocity"] for m in WHEELS)
    assert wheel_fresh_window_s(robot) == pytest.approx(robot.safety.stale_after_periods * slowest)


def test_a_drive_goes_as_far_with_a_wheel_sensor_dropped_out() -> None:
    params = {"distance": "0.5 m"}
    clean = pirate_bt.simulate_tree(STRAIGHT, params=params)
    dropped = pirate_bt.simulate_tree(
        STRAIGHT, params=params, faults="sensor_dropout:bend_1_drive.velocity@1s"
    )
    assert clean.succeeded and dropped.succeeded, (clean.why, dropped.why)
    assert dropped.ticks == clean.ticks  # was 207 against 182: a fifth further


def test_a_drive_goes_as_far_with_a_wheel_sensor_stuck_but_fresh() -> None:
    # the sensor keeps reporting the 0 m/s it read before the drive began, fresh each
    # frame; before the cross-check the drive went a fifth further (207 ticks, not 182:
    # 25 ticks more at 80 mm/s, 0.1 m)
    params = {"distance": "0.5 m"}
    clean = pirate_bt.simulate_tree(STRAIGHT, params=params)
    stuck = pirate_bt.simulate_tree(
        STRAIGHT, params=params, faults="sensor_stuck:bend_1_drive.velocity@0.1s"
    )
    assert clean.succeeded and stuck.succeeded, (clean.why, stuck.why)
    assert stuck.ticks == clean.ticks
