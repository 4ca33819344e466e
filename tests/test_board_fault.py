"""A board that reports FAULT (an H-bridge fault or over-current), and a bus in BUS_FAULT.

The bridge passes on each board's FAULT bit and its own BUS_FAULT flag in every STATE
(docs/protocol.md). The host used to ignore both: a clamp board whose H-bridge had cut
out left its half limp while the tree went on, and a run ended in success. Now the link
reports them (``LinkHealth.faulted_boards``, ``bus_fault``), the supervisor puts the
robot in its safe state naming the boards (a hardware error: exit 3), and its
protective hold still reaches the boards that work. The simulator injects the fault
(``board_fault:BOARD@AT[+DURATION]``).
"""

from __future__ import annotations

from pathlib import Path

import pytest
from session_wire import LAYOUT, Wire

import pirate_bt
from pirate_bt.clock import SimClock
from pirate_bt.errors import LinkError
from pirate_bt.link.codec import BoardStatus, BridgeFlags, State
from pirate_bt.link.robot_link import RobotLink
from pirate_bt.robot import load_robot
from pirate_bt.robot.commands import MotorCommand
from pirate_bt.robot.description import ControlMode, Half
from pirate_bt.safety import Clamp, Reason, Source, Supervisor
from pirate_bt.safety.testing import FakePort
from pirate_bt.sim import Simulator, parse_fault
from pirate_bt.sim.faults import FaultTargetError

ROBOT = load_robot()
DROP = Path(__file__).parents[1] / "tests" / "data" / "networks" / "drop.yaml"
BOARDS = ROBOT.board_ids()


def status_with(**nibbles: int) -> tuple[int, ...]:
    """Every board ONLINE, but those given as ``b26=...``."""
    return tuple(nibbles.get(f"b{b}", int(BoardStatus.ONLINE)) for b in BOARDS)


def frame(seq: int, status: tuple[int, ...], flags: BridgeFlags = BridgeFlags.NONE) -> State:
    return State(seq, flags, 0, 0, status, (0,) * LAYOUT.n_channels)


# -- the link reports them -------------------------------------------------------------


def test_the_link_reports_the_boards_in_fault_and_when_they_recover() -> None:
    wire = Wire()
    link = RobotLink(ROBOT, wire.session)
    assert link.health().faulted_boards == () and not link.health().bus_fault
    faulty = int(BoardStatus.ONLINE | BoardStatus.FAULT)
    wire.answer(frame(1, status_with(b26=faulty, b22=faulty)))
    wire.poll()
    assert link.health().faulted_boards == (22, 26)  # ids, ascending, as the frame's order
    assert wire.session.stats().faulted == (BOARDS.index(22), BOARDS.index(26))
    wire.answer(frame(2, status_with()))
    wire.poll()
    assert link.health().faulted_boards == ()


def test_the_link_reports_bus_fault() -> None:
    wire = Wire()
    link = RobotLink(ROBOT, wire.session)
    timeout = int(BoardStatus.TIMEOUT)
    wire.answer(frame(1, tuple(timeout for _ in BOARDS), BridgeFlags.BUS_FAULT))
    wire.poll()
    assert link.health().bus_fault and wire.session.stats().bus_fault
    wire.answer(frame(2, status_with()))
    wire.poll()
    assert not link.health().bus_fault


# -- the supervisor stops on them ------------------------------------------------------


def test_a_board_in_fault_puts_the_robot_in_its_safe_state_naming_it() -> None:
    clock = SimClock(100.0)
    port = FakePort(ROBOT, clock)
    sup = Supervisor(port, clock)
    sup.tick()
    assert not sup.in_safe_state
    port.faulted_boards = (26,)
    sup.tick()
    reason = sup.safe_state_reason
    assert reason is not None and reason.startswith("board_fault: board 26 (bend_3_joint")
    assert "FAULT" in reason
    verdict = sup.check(pirate_bt.safety.Drive(0.02))
    assert verdict.refused
    # the robot is held: the operator cannot resume while the board is in fault
    problem = sup.link_problem()
    assert problem is not None and problem.reason is Reason.BOARD_FAULT


def test_bus_fault_puts_the_robot_in_its_safe_state() -> None:
    clock = SimClock(100.0)
    port = FakePort(ROBOT, clock)
    sup = Supervisor(port, clock)
    port.bus_fault = True
    sup.tick()
    assert (sup.safe_state_reason or "").startswith("bus_fault: the bridge reports BUS_FAULT")


# -- the simulated board -------------------------------------------------------------


def test_the_fault_text_names_a_board() -> None:
    fault = parse_fault("board_fault:26@3s+2s")
    assert (fault.kind, fault.target, fault.at, fault.duration) == ("board_fault", "26", 3.0, 2.0)
    with pytest.raises(FaultTargetError, match="board_fault: unknown board '99'"):
        Simulator("straight", ROBOT, clock=SimClock(), faults=["board_fault:99@1s"])


def test_a_faulted_board_has_its_motors_off_and_gets_its_setpoints_back() -> None:
    clock = SimClock()
    with Simulator("straight", ROBOT, clock=clock, faults=["board_fault:22@2s+1s"]) as sim:
        clamp = [MotorCommand(f"bend_{i}_joint", ControlMode.TORQUE, 0.7) for i in (1, 2)]
        for command in clamp:
            sim.model.command(command)
        clock.advance(1.9)
        assert sim.truth().halves[Half.FRONT].clamped
        clock.advance(0.3)  # in the fault: the H-bridge is off, the half goes limp
        assert sim.model.setpoint("bend_1_joint") is None
        assert sim.model.setpoint("bend_2_joint") == clamp[1]  # another board's
        assert not sim.truth().halves[Half.FRONT].clamped
        # a setpoint given during the fault is what the board holds when it ends
        drive = MotorCommand("bend_1_drive", ControlMode.VELOCITY, 0.0)
        sim.model.command(drive)
        clock.advance(0.1)
        assert sim.model.setpoint("bend_1_drive") is None
        clock.advance(1.0)
        assert sim.model.setpoint("bend_1_joint") == clamp[0]
        assert sim.model.setpoint("bend_1_drive") == drive
        assert sim.truth().halves[Half.FRONT].clamped
        kinds = [e.detail for e in sim.events()]
        assert "start board_fault 22" in kinds and "end board_fault 22" in kinds


def test_the_bridge_will_not_reset_its_estop_while_a_board_is_in_fault() -> None:
    with pirate_bt.connect("straight", faults="board_fault:26@1s+1s") as robot:
        port = robot.supervisor._port  # the link itself, around the supervisor

        def until(t_s: float) -> None:
            while robot.clock.now() < t_s:
                robot.clock.advance(0.01)
                port.poll()

        until(1.2)
        assert port.health().faulted_boards == (26,)
        port.estop()
        until(1.3)
        assert port.health().estopped
        with pytest.raises(LinkError, match="NOT_READY"):
            port.reset_estop()  # as the firmware bridge: no confirming its motors are held
        until(2.1)
        assert port.health().faulted_boards == ()
        port.reset_estop()
        until(2.2)
        assert not port.health().estopped


# -- end to end ------------------------------------------------------------------------


def test_a_run_ends_on_a_board_fault_as_a_hardware_error() -> None:
    result = pirate_bt.simulate_tree(
        "straight", params={"distance": "1 m"}, network="straight", faults="board_fault:26@3s"
    )
    assert not result.succeeded
    assert result.exit_code == 3
    assert result.why.startswith("board_fault: board 26 (bend_3_joint, bend_3_drive)")


def test_in_a_drop_the_other_half_is_clamped_when_the_holding_half_goes_limp() -> None:
    # the front half alone holds the robot in the shaft at 24 s when board 22's H-bridge
    # cuts out: its half goes limp while the board still answers; the supervisor stops
    # on the fault and, the link being up, clamps the rear half at once
    with pirate_bt.connect(DROP, faults="board_fault:22@24s") as robot:
        result = robot.run("bend", params={"roll": "180 deg"}, max_time="120 s")
        sim = robot.simulator
        assert sim is not None
        assert result.why.startswith("board_fault: board 22 (bend_1_joint, bend_1_drive)")
        held = [
            (v.command.half.value, v.tick)
            for v in robot.supervisor.verdicts
            if isinstance(v.command, Clamp) and v.source is Source.SUPERVISOR
        ]
        # both halves: the front's clamp is what its board holds when the fault ends
        assert sorted(h for h, _ in held) == ["front", "rear"]
        truth = sim.truth()
        assert truth.halves["rear"].clamped and not truth.sliding
        front = truth.front_m
        robot.clock.advance(5.0)
        assert abs(sim.truth().front_m - front) < 0.01
