"""Probe 17 of the simulator: vertical pipes, and the files a user feeds it.

A robot put into a riser (or onto any start steeper than ``motion.max_unclamped_slope``)
slid from the simulator's first step, before any tree could clamp: every run and mission
that started there was judged *the robot did not stay safe*, however quickly its first
clamp held. It is put in held now, as an operator holds a robot on its tether until it
clamps; from its first clamp on, an unclamped robot falls as before.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import pytest

import pirate_bt
from pirate_bt.cli import main
from pirate_bt.clock import SimClock
from pirate_bt.errors import InputError, ValidationFailed
from pirate_bt.pipes import Network, network_from_data
from pirate_bt.robot import Half, load_robot
from pirate_bt.robot.commands import MotorCommand
from pirate_bt.robot.description import ControlMode
from pirate_bt.sim import Simulator
from pirate_bt.sim.faults import FaultTargetError
from pirate_bt.sim.server import end_state

ROBOT = load_robot()


def _shaft(slope: str = "90 deg", start: str | None = "1 m", length: str = "4 m") -> Network:
    data: dict[str, Any] = {
        "name": "shaft",
        "diameter": "63 mm",
        "slope": slope,
        "segments": [{"id": "shaft", "type": "straight", "length": length}],
    }
    if start is not None:
        data["start"] = {"position": start}
    return network_from_data(data)


def _joints(sim: Simulator, half: Half, mode: ControlMode, value: float) -> None:
    for module in ROBOT.bend_modules(half):
        sim.model.command(MotorCommand(ROBOT.joint_motor(module.name).name, mode, value))


def _run(sim: Simulator, clock: SimClock, seconds: float) -> None:
    clock.advance(seconds)
    sim.advance_to(clock.now())


def test_a_robot_put_in_a_riser_is_held_until_its_first_clamp_then_falls_unclamped() -> None:
    clock = SimClock()
    with Simulator(_shaft(), ROBOT, clock=clock) as sim:
        _run(sim, clock, 2.0)  # nobody clamps yet: the operator holds it where put in
        truth = sim.truth()
        assert not truth.sliding and truth.front_m == 1.0  # was: slid 0.2 m/s from 0.01 s
        assert sim.counters().violation_count == 0
        assert end_state(sim).startswith(
            "end state: robot held where it was put in, no half clamped yet on a 90 deg slope"
        )
        _joints(sim, Half.REAR, ControlMode.TORQUE, 0.5)
        _run(sim, clock, 1.5)
        assert sim.truth().halves[Half.REAR].clamped and not sim.model.held_as_put_in
        assert end_state(sim).startswith("end state: robot at rest, drives stopped")
        _joints(sim, Half.REAR, ControlMode.POSITION, 0.0)  # let go: now it falls
        _run(sim, clock, 1.5)
        assert sim.truth().front_m < 1.0
        assert dict(sim.counters().violations) == {"sliding": 1}


def test_a_tree_that_starts_in_a_riser_is_not_judged_unsafe_for_its_insertion() -> None:
    for network in (_shaft(), _shaft(start=None), _shaft(slope="-15 deg")):
        result = pirate_bt.simulate_tree("straight", network=network, params={"distance": "0.3 m"})
        assert result.status == "success", result.why
        # was: '...; but the simulator counted 1 sliding violation: the robot did not stay safe'
        assert result.why.startswith("tree succeeded") and "not stay safe" not in result.why
        assert result.counters.violations == 0, result.counters


def test_a_level_start_is_not_affected() -> None:
    clock = SimClock()
    with Simulator(_shaft(slope="0 deg"), ROBOT, clock=clock) as sim:
        _run(sim, clock, 1.0)
        assert end_state(sim).startswith("end state: robot at rest, drives stopped")
        assert math.isclose(sim.truth().front_m, 1.0)


NETWORK = """schema_version: 1
name: f
diameter: 63 mm
segments:
  - {id: a, type: straight, length: 2 m}
faults:
  - {kind: link_loss, at: 1 s}
"""


def test_a_network_file_s_fault_naming_no_motor_is_refused_at_its_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    net = tmp_path / "f.yaml"
    net.write_text(NETWORK + "  - kind: motor_stall\n    at: 1 s\n    target: nosuch\n")
    argv = ["run", "straight", "--sim", str(net), "--param", "distance=0.2m", "--quiet"]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    # was: 'f.yaml: faults: fault motor_stall: ...', the file but not the place
    assert err.startswith(f"pirate-bt: {net}:10:5: faults: fault motor_stall: unknown motor")
    assert "\n" not in err


def test_a_network_file_s_fault_with_no_target_says_it_needs_one(tmp_path: Path) -> None:
    net = tmp_path / "f.yaml"
    net.write_text(NETWORK + "  - {kind: board_reset, at: 2 s}\n")
    # the network itself is refused, at the fault (as `pirate-bt validate` does): it was
    # 'fault board_reset: unknown board None (boards: ...)', with no line, from the
    # simulator only, while validate said the file was valid
    with pytest.raises(ValidationFailed) as refused:
        Simulator(net, ROBOT)
    assert str(refused.value).startswith(f"{net}:8:5: board_reset needs a target: a board id")
    data = {
        "name": "f",
        "diameter": "63 mm",
        "segments": [{"type": "straight", "length": "2 m"}],
        "faults": [{"kind": "board_reset", "at": "2 s"}],
    }
    with pytest.raises(ValidationFailed, match=r"^<data>:1:1: board_reset needs a target"):
        network_from_data(data)
    # and a link loss given a target, which the simulator refused after validate passed
    net.write_text(NETWORK + '  - {kind: link_loss, at: 2 s, target: "22"}\n')
    with pytest.raises(ValidationFailed, match=r"f\.yaml:8:32: link_loss takes no target"):
        Simulator(net, ROBOT)


def test_a_list_of_faults_with_one_refused_schedules_none_of_them() -> None:
    clock = SimClock()
    with Simulator("straight", ROBOT, clock=clock) as sim:
        with pytest.raises(FaultTargetError, match="unknown motor 'nosuch'"):
            sim.schedule(["motor_stall:bend_1_drive@1s", "motor_stall:nosuch@1s"])
        _run(sim, clock, 2.0)
        # was: the refused list's first fault was scheduled all the same
        assert not [e for e in sim.events() if e.kind.value == "fault"], sim.events()


@pytest.mark.parametrize("start", [math.nan, math.inf, "1 m"])
def test_a_start_that_is_no_finite_distance_is_refused(start: Any) -> None:
    # nan put the robot's front tip at nan metres and the simulator ran on; text
    # raised a TypeError from inside the model
    with pytest.raises(InputError, match=r"^start_m: the front tip's distance is a finite"):
        Simulator("straight", ROBOT, start_m=start)
    with Simulator("straight", ROBOT, start_m=1e300) as sim:  # kept to the path's end
        assert sim.truth().front_m == 5.0
