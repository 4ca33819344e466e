"""Probe 8 of the protective layer: guards on readings that went stale.

A reading whose sensor dropped out (or whose board went away) keeps its last value.
The guards compared it as if it were current: ``is_clamped rear`` succeeded on the
readings of a half whose board had gone, and ``while: imu.pitch < 10 deg`` went on
holding on the pitch the IMU read before it dropped out. A guard never lets a child
through on a guess; a stale reading is one.
"""

from __future__ import annotations

from typing import Any

import py_trees
import pytest
from py_trees.common import Status
from safety_rig import rig

from pirate_bt.behaviours.guards import is_clamped, skip_if, while_
from pirate_bt.robot import Half, load_robot

ROBOT = load_robot()
REAR = ("bend_3_angle", "bend_3_spring", "bend_4_angle", "bend_4_spring")


def _status(node: py_trees.behaviour.Behaviour) -> Status:
    return node.status


def test_is_clamped_fails_on_stale_readings_of_its_half() -> None:
    sup, port, clock = rig()
    node = is_clamped(sup, Half.REAR)
    assert node.update() is Status.SUCCESS
    port.freeze(*REAR)
    clock.advance(2.0)
    assert node.update() is Status.FAILURE  # was SUCCESS on 2 s old readings
    assert node.feedback_message == (
        "rear half clamped by readings that are stale: bend_3_angle (2.000 s),"
        " bend_3_spring (2.000 s), bend_4_angle (2.000 s), bend_4_spring (2.000 s)"
    )
    assert is_clamped(sup, Half.FRONT).update() is Status.FAILURE  # fresh, and unclamped


@pytest.mark.parametrize(
    ("condition", "frozen"),
    [
        ({"state": "imu.pitch", "op": "<", "value": 0.1}, "imu.pitch"),
        ({"state": "half.rear", "op": "==", "value": "clamped"}, "bend_4_spring"),
        ({"state": "joint_angle.bend_3", "op": ">", "value": 1.0}, "bend_3_angle"),
        (
            {"state": "drive_velocity.bend_1_drive", "op": "<", "value": 0.1},
            "bend_1_drive.velocity",
        ),
    ],
)
def test_a_guard_on_a_stale_reading_fails(condition: dict[str, Any], frozen: str) -> None:
    sup, port, clock = rig()
    guard = while_(py_trees.behaviours.Running("go"), condition, sup)
    guard.tick_once()
    assert guard.status is Status.RUNNING
    port.freeze(frozen)
    clock.advance(1.0)
    guard.tick_once()
    # was RUNNING: the stale value still held
    assert _status(guard) is Status.FAILURE
    assert guard.feedback_message == (
        f"{condition['state']} cannot be read: stale: {frozen} (1.000 s)"
    )
    skip = skip_if(py_trees.behaviours.Success("s"), condition, sup)
    skip.tick_once()
    assert skip.status is Status.FAILURE


def test_the_drives_mean_speed_is_read_from_the_wheels_that_read_fresh() -> None:
    sup, port, clock = rig()
    port.freeze("bend_1_drive.velocity")  # one wheel's sensor dropped out
    clock.advance(1.0)
    guard = while_(
        py_trees.behaviours.Running("go"), {"state": "drive_velocity", "op": "<", "value": 0.1}, sup
    )
    guard.tick_once()
    assert guard.status is Status.RUNNING
    port.freeze(*(f"{m.name}.velocity" for m in ROBOT.drive_motors()))
    clock.advance(1.0)
    guard.tick_once()
    assert _status(guard) is Status.FAILURE
    assert guard.feedback_message.startswith("drive_velocity cannot be read: stale: bend_1_drive")
