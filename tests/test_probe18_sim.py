"""Probe 18: the simulator's scripted faults with hostile times, and its physics in risers.

Each test names what a user saw before its fix.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import pytest

from pirate_bt.api.fault_text import fault_items, split_faults
from pirate_bt.cli.faults_option import check_faults_option
from pirate_bt.clock import SimClock
from pirate_bt.errors import ArgumentTypeError, ArgumentValueError, ConfigurationError, LocatedError
from pirate_bt.pipes import network_from_data
from pirate_bt.robot import Half, load_robot
from pirate_bt.robot.commands import MotorCommand
from pirate_bt.robot.description import ControlMode
from pirate_bt.sim import SensorNoise, Simulator
from pirate_bt.sim.server import end_state

ROBOT = load_robot()

# -- a fault before the simulated time ---------------------------------------------------


def test_a_fault_scheduled_before_the_simulated_time_is_refused_not_a_blip() -> None:
    # sim.schedule("board_reset:22@5s") at 10 s was taken: the board's reset started and
    # ended in the same step (its 1.5 s ended at 6.5 s), so the board was never missed,
    # while the events said "start board_reset 22", "end board_reset 22"
    with Simulator("straight") as sim:
        sim.advance_to(10.0)
        with pytest.raises(ArgumentValueError) as refused:
            sim.schedule(["link_loss@11s+1s", "board_reset:22@5s"])
        assert str(refused.value) == (
            "faults: board_reset:22@5s starts at 5 s, but the simulated time is 10 s already"
            " (a fault's time is the simulator's clock time): give 10 s or later"
        )
        sim.advance_to(11.5)
        assert not [e for e in sim.events() if e.kind == "fault"]  # all or none
        sim.schedule("link_loss@11.5s+1s")  # now is not too early
        sim.advance_to(12.0)
        assert [e.detail for e in sim.events() if e.kind == "fault"] == ["start link_loss"]


def test_faults_before_a_shared_clock_s_time_are_refused_where_they_are_written(
    tmp_path: Path,
) -> None:
    # a simulator made on a clock at 100 s took faults=["motor_stall:bend_1_drive@5s+20s"]
    # and ran it for no time at all
    with pytest.raises(ArgumentValueError, match=r"^faults: motor_stall:bend_1_drive@5s\+20s"):
        Simulator("straight", clock=SimClock(100.0), faults="motor_stall:bend_1_drive@5s+20s")
    network = tmp_path / "net.yaml"
    network.write_text(
        "schema_version: 1\nname: net\ndiameter: 63 mm\nsegments:\n"
        "  - {id: s, type: straight, length: 2 m}\nfaults:\n"
        "  - {kind: link_loss, at: 5 s}\n  - {kind: board_reset, target: '22', at: 1 s}\n"
    )
    with pytest.raises(ConfigurationError) as refused:
        Simulator(network, clock=SimClock(3.0))
    assert str(refused.value).startswith(f"{network}:8:39: faults: board_reset:22@1s starts at 1 s")
    with Simulator(network, clock=SimClock(1.0)) as sim:  # at the clock's time: taken
        sim.advance_to(1.05)
        assert [e.detail for e in sim.events() if e.kind == "fault"] == ["start board_reset 22"]


# -- sensor noise --------------------------------------------------------------------


@pytest.mark.parametrize(
    ("field", "value", "error"),
    [
        ("force_n", math.inf, ArgumentValueError),  # OverflowError at the first STATE frame
        ("angle_rad", math.nan, ArgumentValueError),  # taken: silently no noise
        ("angle_rad", -0.5, ArgumentValueError),  # taken
        ("current_a", "0.01", ArgumentTypeError),  # TypeError at the first STATE frame
        ("velocity_mps", True, ArgumentTypeError),
    ],
)
def test_a_noise_that_is_no_standard_deviation_is_refused_naming_it(
    field: str, value: object, error: type[Exception]
) -> None:
    with pytest.raises(error, match=rf"^noise: {field}: "):
        SensorNoise(**{field: value})  # type: ignore[arg-type]


def test_a_valid_noise_still_runs() -> None:
    with Simulator("straight", noise=SensorNoise(force_n=3, angle_rad=0.01)) as sim:
        sim.advance_to(0.05)
        assert sim.counters().state_frames_sent == 5


# -- spaces around a fault's '@' and '+' -----------------------------------------------


def test_spaces_around_a_fault_s_at_and_plus_keep_it_one_fault() -> None:
    # --faults "link_loss@2s + 1s" said "--faults:1:14: link fault '+' is not key=value"
    # (the '+' was split off as a link fault), though parse_fault reads the fault with
    # those spaces, and faults=["link_loss@2s + 1s"] as a list item was taken
    assert split_faults("link_loss@2s + 1s, drop=0.05") == (["link_loss@2s + 1s"], "drop=0.05")
    assert fault_items("board_reset:22 @ 1 s;corrupt=0.01") == [
        (1, "board_reset:22 @ 1 s"),
        (22, "corrupt=0.01"),
    ]
    args = argparse.Namespace(faults="drop=0.05 motor_stall:bend_3_drive@5s + 20s")
    check_faults_option(args, ROBOT)  # nothing to refuse
    args = argparse.Namespace(faults="drop=0.05 motor_stall:nosuch@5s + 20s")
    with pytest.raises(LocatedError, match=r"^--faults:1:11: fault motor_stall: unknown motor"):
        check_faults_option(args, ROBOT)
    with Simulator("straight", faults=split_faults("link_loss @ 1s + 1s")[0]) as sim:
        sim.advance_to(2.5)
        faults = [(e.time_s, e.detail) for e in sim.events() if e.kind == "fault"]
    assert [detail for _, detail in faults] == ["start link_loss", "end link_loss"]
    assert faults[0][0] == pytest.approx(1.0, abs=0.011)  # as written: from 1 s for 1 s
    assert faults[1][0] == pytest.approx(2.0, abs=0.011)


@pytest.mark.parametrize("network", [None, 123, b"straight", ["straight"]])
def test_a_network_that_is_none_is_refused_naming_the_network(network: object) -> None:
    # said "path: give a file name (text or a Path), not None": no argument is called path
    with pytest.raises(ArgumentTypeError, match=r"^network: give a Network, a file name or a"):
        Simulator(network)  # type: ignore[arg-type]


# -- a slide that reached an end of the path ---------------------------------------------


def _released_in(slope: str, seconds: float) -> str:
    """The end state of a robot clamped in a straight of ``slope``, then let go."""
    net = network_from_data(
        {
            "name": "steep",
            "diameter": "63 mm",
            "slope": slope,
            "segments": [{"id": "s", "type": "straight", "length": "1 m"}],
        }
    )
    with Simulator(net) as sim:
        rear = ("bend_3_joint", "bend_4_joint")
        for joint in rear:
            sim.model.command(MotorCommand(joint, ControlMode.TORQUE, 0.7))
        sim.advance_to(2.0)
        assert sim.truth().halves[Half.REAR].clamped
        for joint in rear:
            sim.model.command(MotorCommand(joint, ControlMode.POSITION, 0.0))
        sim.advance_to(2.0 + seconds)
        assert sim.counters().violations == {"sliding": 1}
        return end_state(sim)


def test_a_slide_that_reached_the_end_of_a_drop_is_not_said_to_slide_at_0_m_s() -> None:
    # said "robot sliding at 0.000 m/s" once the robot lay on the cap of the drop
    assert _released_in("-90 deg", 1.0).startswith("end state: robot sliding at 0.200 m/s,")
    assert _released_in("-90 deg", 4.0).startswith(
        "end state: robot slid to the pipe's end and lies there, no half holding it,"
    )
    assert _released_in("90 deg", 1.0).startswith(
        "end state: robot slid back out of the pipe's entry (the simulator keeps it there),"
    )


def test_a_board_id_written_as_a_number_in_a_network_file_is_the_board() -> None:
    # 'target: 22' (YAML reads a number) was refused as 'target: must be text, not 22',
    # while the octal hint for 'target: 022' said to write 22
    network = network_from_data(
        {
            "name": "n22",
            "diameter": "63 mm",
            "segments": [{"type": "straight", "length": "2 m"}],
            "faults": [{"kind": "board_reset", "target": 22, "at": "1 s"}],
        }
    )
    (fault,) = network.spec.faults
    assert fault.target == "22"
    clock = SimClock()
    with Simulator(network, clock=clock) as sim:
        clock.advance(1.2)
        assert [e.detail for e in sim.events() if e.kind == "fault"] == ["start board_reset 22"]
