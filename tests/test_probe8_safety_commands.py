"""Probe 8 of the protective layer: commands planner code builds by hand.

Commands are plain dataclasses anyone can fill with anything. A half given as text
(``Clamp("rear", 0.7)``) passed with nothing sent, since the checks compare halves by
identity and no bend module is of the half ``"rear"``; ``Unclamp(None)``,
``Drive(None)`` or a ``Raw`` of a string raised from deep in the checks, and the trace's
form of a refused malformed command raised too.
"""

from __future__ import annotations

from typing import Any

import pytest
from safety_rig import rig

from pirate_bt.robot import Half, MotorCommand
from pirate_bt.safety import (
    Clamp,
    Drive,
    MoveFrontClear,
    Outcome,
    Raw,
    Reason,
    Unclamp,
    describe,
)


def test_a_half_given_as_text_is_that_half() -> None:
    sup, _, _ = rig()
    verdict = sup.command(Clamp("front", 0.7))  # type: ignore[arg-type]
    # was: PASS with nothing sent (no bend module is of the half "front")
    assert verdict.ok and {c.motor for c in verdict.sent} == {"bend_1_joint", "bend_2_joint"}
    assert isinstance(verdict.command, Clamp) and verdict.command.half is Half.FRONT
    assert sup.check(Unclamp("rear")).refused  # type: ignore[arg-type]  # the front is not clamped


@pytest.mark.parametrize(
    "command",
    [
        Clamp(None, 0.7),  # type: ignore[arg-type]
        Clamp("middle", 0.7),  # type: ignore[arg-type]
        Unclamp(None),  # type: ignore[arg-type]
        Drive(None),  # type: ignore[arg-type]
        Drive("0.05"),  # type: ignore[arg-type]
        Drive(True),
        MoveFrontClear("up"),  # type: ignore[arg-type]
        Raw("bend_1_joint"),  # type: ignore[arg-type]
        Raw(MotorCommand("bend_1_joint", "torque", "0.5")),  # type: ignore[arg-type]
        Raw(MotorCommand("bend_1_joint", "spin", 0.5)),  # type: ignore[arg-type]
        "drive",
    ],
    ids=repr,
)
def test_a_malformed_command_is_refused_and_recorded(command: Any) -> None:
    sup, port, _ = rig()
    sent = len(port.sent)
    verdict = sup.command(command)  # raised AttributeError or TypeError for most
    assert verdict.refused
    assert verdict.reason in (Reason.UNKNOWN_TARGET, Reason.NOT_FINITE, Reason.MODE_NOT_ALLOWED)
    assert len(port.sent) == sent
    record = verdict.to_record()  # the trace's form of it (describe raised)
    assert record["command"] == describe(command)


def test_numbers_of_other_kinds_are_read_as_floats() -> None:
    sup, _, _ = rig()
    verdict = sup.command(Raw(MotorCommand("bend_4_joint", "torque", 1)))  # type: ignore[arg-type]
    assert verdict.outcome is Outcome.REFUSE and verdict.reason is Reason.TORQUE_LIMIT
    assert sup.command(Clamp(Half.REAR, 0.7)).ok
