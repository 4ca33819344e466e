"""The scripted reference drive: through the whole lab network, by model and by link."""

from __future__ import annotations

import math

import pytest

from pirate_bt.clock import SimClock
from pirate_bt.link import open_link
from pirate_bt.robot import load_robot
from pirate_bt.sim import Simulator
from pirate_bt.sim.script import LinkSink, ModelSink, ScriptedDrive, rotation_for_turn

ROBOT = load_robot()


@pytest.mark.parametrize(
    ("turn_deg", "rear_deg", "rotation_deg", "sign"),
    [(0, 0, 0, 1), (90, 0, 90, 1), (-90, 0, -90, 1), (180, 0, 0, -1), (90, 90, 0, 1)],
)
def test_rotation_for_turn(
    turn_deg: float, rear_deg: float, rotation_deg: float, sign: int
) -> None:
    rotation, steer = rotation_for_turn(math.radians(turn_deg), math.radians(rear_deg))
    assert math.degrees(rotation) == pytest.approx(rotation_deg, abs=1e-9)
    assert steer == sign


def test_scripted_drive_through_the_lab() -> None:
    with Simulator("lab", ROBOT) as sim:
        ScriptedDrive(sim, ModelSink(sim)).run_path()
        counters = sim.counters()
        truth = sim.truth()
    assert counters.stuck_events == 0
    assert counters.violation_count == 0
    assert counters.damage_count == 0
    assert truth.module_segment["front"] == "riser"
    assert truth.path_choices == {"tee-1": "straight", "tee-2": "straight"}
    assert counters.distance_m > 29.0


def test_scripted_drive_through_a_bend_over_the_host_link() -> None:
    clock = SimClock()
    with Simulator("bend-left", ROBOT, clock=clock) as sim:
        link = open_link(sim.url, ROBOT, clock)
        try:
            ScriptedDrive(sim, LinkSink(link, clock)).run_path()
        finally:
            link.close()
        counters = sim.counters()
        assert counters.stuck_events == 0
        assert sim.truth().module_segment["rear"] == "after"
        assert counters.frames_rejected == 0
        assert counters.commands_executed > 20


def test_tee_branch_by_script() -> None:
    with Simulator("t-joint", ROBOT) as sim:
        drive = ScriptedDrive(sim, ModelSink(sim))
        drive.start()
        tee = next(p for p in sim.model.path.pieces if p.segment == "tee")
        branch = sim.network.path({"tee": "branch"})
        turn = next(p for p in branch.pieces if p.is_turn)
        assert tee.opening_m is not None
        drive.through_turn(turn)
        assert sim.truth().path_choices == {"tee": "branch"}
        assert sim.truth().module_segment["rear"] == "branch"
        assert sim.counters().stuck_events == 0
