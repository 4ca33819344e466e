"""Probe 8 of the protective layer: what planner code can hand the supervisor.

Commands are plain dataclasses and ``source`` a plain argument, so planner code can
put anything in them. The supervisor used to take some of it on trust: a ``source``
other than the tree's or the operator's skipped every authority check (a drive went
out in the safe state and while the operator held manual control), a half given as
text passed with nothing sent, and malformed values raised from deep in the checks.
"""

from __future__ import annotations

from typing import Any

import pytest
from safety_rig import rig

from pirate_bt.robot import ControlMode, MotorCommand, load_robot
from pirate_bt.safety import (
    Drive,
    Mode,
    Outcome,
    Reason,
    SetMode,
    Source,
    Stop,
)
from pirate_bt.safety.testing import FakePort

ROBOT = load_robot()


def _drives(port: FakePort) -> list[MotorCommand]:
    return [c for c in port.sent if c.mode is ControlMode.VELOCITY and c.value != 0.0]


@pytest.mark.parametrize("source", [Source.SUPERVISOR, "supervisor", "tree"])
def test_no_source_drives_in_the_safe_state(source: Any) -> None:
    sup, port, _ = rig()
    sup.safe_state("test")
    verdict = sup.command(Drive(0.01), source=source)
    # Source.SUPERVISOR (and any text) passed: the drive went out in the safe state
    assert verdict.refused and verdict.reason is Reason.SAFE_STATE
    assert not _drives(port)


@pytest.mark.parametrize("source", [Source.SUPERVISOR, "supervisor", "tree"])
def test_no_source_drives_while_the_operator_has_control(source: Any) -> None:
    sup, port, _ = rig()
    sup.apply(SetMode(Mode.MANUAL))
    verdict = sup.command(Drive(0.01), source=source)
    assert verdict.refused and verdict.reason is Reason.TREE_PAUSED
    assert not _drives(port)


def test_the_operator_as_text_is_the_operator() -> None:
    sup, _, _ = rig()
    verdict = sup.command(Drive(0.01), source="operator")  # type: ignore[arg-type]
    # was: passed in autonomous mode, as if no one were asking
    assert verdict.refused and verdict.reason is Reason.OPERATOR_NOT_IN_CONTROL
    assert verdict.source is Source.OPERATOR
    sup.apply(SetMode(Mode.MANUAL))
    verdict = sup.command(Drive(0.01), source="operator")  # type: ignore[arg-type]
    assert verdict.ok and verdict.source is Source.OPERATOR
    assert {c.motor for c in verdict.sent} == {m.name for m in ROBOT.drive_motors()}


@pytest.mark.parametrize("source", [None, "robot", 3])
def test_an_unknown_source_is_refused_and_a_stop_still_passes(source: Any) -> None:
    sup, port, _ = rig()
    verdict = sup.command(Drive(0.01), source=source)
    assert verdict.refused and verdict.reason is Reason.UNKNOWN_TARGET
    assert "not a source" in verdict.detail
    assert not _drives(port)
    assert sup.command(Stop(), source=source).outcome is Outcome.PASS
