"""Probe 16 of the protective layer: planner code written from the docs, third round.

Sequences of public commands and operator actions that are each fine alone, on the
simulator (a level pipe and a vertical shaft): what the robot does after them, by the
simulator's truth, and what the run says.
"""

from __future__ import annotations

from fractions import Fraction
from typing import Any

import pytest

import pirate_bt
from pirate_bt.clock import SimClock
from pirate_bt.robot import ControlMode, Half, MotorCommand, load_robot
from pirate_bt.safety import Bend, Clamp, Drive, MoveFrontClear, Raw, Reason, Supervisor
from pirate_bt.safety.commands import describe
from pirate_bt.safety.operator import Mode, OperatorCommand, ScriptedOperator, SetMode
from pirate_bt.safety.testing import FakePort

ROBOT = load_robot()

HOLD: list[dict[str, Any]] = [
    {"type": "clamp", "name": "clamp rear", "half": "rear", "torque": "0.7 N*m"},
    {"type": "move_front_clear", "name": "clear"},
    {"type": "clamp", "name": "clamp front", "half": "front", "torque": "0.7 N*m"},
]


def _tree(*children: dict[str, Any]) -> dict[str, Any]:
    return {"name": "probe", "root": {"type": "sequence", "children": list(children)}}


def _held(network: Any = "straight") -> Any:
    """A connection whose robot holds the pipe with both halves, the front module clear."""
    robot = pirate_bt.connect(network)
    result = robot.run(_tree(*HOLD), max_time="30 s")
    assert result.status == "success", result.why
    return robot


# -- operator authority ----------------------------------------------------------------


def test_a_hand_back_does_not_leave_the_tree_s_drive_on_the_operator_s_wheels() -> None:
    # Taking over pauses the tree; handing back resumes it (docs/console.md). The
    # operator drove back by hand and handed back with the wheels still turning back:
    # the resumed drive never asked again (its wheels were turning) and counted the
    # backward turns as its 0.3 m, succeeding with the robot back where it started
    # (until 2026-11-30). Handing back now stops the drives, and the drive asks again.
    with _held() as robot:
        sim = robot.simulator
        sup = robot.supervisor
        start = sim.truth().front_m
        k = sup.tick_count
        back = [(k + 61 + i, OperatorCommand(Drive(-0.05))) for i in range(20)]
        actions = [(k + 60, SetMode(Mode.MANUAL)), *back, (k + 90, SetMode(Mode.AUTONOMOUS))]
        sup.add_input(ScriptedOperator(at_tick=actions))
        release = {"type": "unclamp", "name": "release front", "half": "front"}
        drive = {"type": "drive", "name": "drive", "velocity": "80 mm/s", "distance": "0.3 m"}
        result = robot.run(_tree(release, drive), max_time="60 s")
        moved = sim.truth().front_m - start
        assert result.status == "success", result.why
        # it drove its 0.3 m forward after the operator's ~0.06 m back (0.0 before)
        assert moved > 0.2, moved
        assert not sim.counters().violations


# -- numbers no float can hold ---------------------------------------------------------

HUGE = 10**400  # an integer: "an integer [is read as] a float" (docs/safety.md)


@pytest.mark.parametrize(
    "command",
    [
        Drive(HUGE),
        Drive(-(10**5000)),  # more digits than Python turns into text, too
        Clamp(Half.REAR, Fraction(HUGE, 3)),
        Bend("bend_1", HUGE),
        MoveFrontClear(HUGE),
        Raw(MotorCommand("bend_1_drive", ControlMode.VELOCITY, HUGE)),
    ],
    ids=["drive", "drive-5000-digits", "clamp-fraction", "bend", "move-clear", "raw"],
)
def test_a_number_too_large_for_a_float_is_refused_not_raised(command: Any) -> None:
    # float(10**400) raises OverflowError: it went up out of Supervisor.command() (and
    # out of describe(), which logs the verdict) as a traceback, where a value that is
    # no finite number is refused not_finite (until 2026-11-30)
    clock = SimClock(100.0)
    port = FakePort(ROBOT, clock)
    sup = Supervisor(port, clock)
    sup.tick()
    verdict = sup.command(command)
    assert verdict.refused and verdict.reason is Reason.NOT_FINITE, verdict
    assert not port.sent
    assert describe(command)  # shown in the log and the trace, whatever it holds
    assert verdict.to_record()["command"]
