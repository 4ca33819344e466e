"""Probe 19: the simulator's faults and physics in vertical pipes, at other angles.

Each test names what a user saw before its fix.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from pirate_bt.api.fault_text import split_faults
from pirate_bt.errors import ArgumentTypeError, ArgumentValueError, InputError
from pirate_bt.link.codec import FrameCodec
from pirate_bt.link.messages import EStopReset, Hello, Setpoint
from pirate_bt.pipes import FaultSpec, Network, network_from_data
from pirate_bt.robot import Half, load_robot
from pirate_bt.robot.commands import MotorCommand
from pirate_bt.robot.description import ControlMode
from pirate_bt.sim import SimCounters, Simulator
from pirate_bt.sim.script import ModelSink, ScriptedDrive
from pirate_bt.sim.server import end_state

ROBOT = load_robot()


def _riser(faults: list[dict[str, str]] | None = None) -> Network:
    """A bend up at 0.3 m, then two metres of vertical pipe: a robot put in at 1.5 m
    hangs in the riser, its rotational module in vertical pipe."""
    return network_from_data(
        {
            "schema_version": 1,
            "name": "up",
            "diameter": "63 mm",
            "segments": [
                {"id": "a", "type": "straight", "length": "0.3 m"},
                {"id": "b", "type": "bend", "direction": "up"},
                {"id": "r", "type": "straight", "length": "2 m"},
            ],
            "faults": faults or [],
        }
    )


def _hanging_on_the_rear_clamp(network: Network | None = None) -> Simulator:
    """A simulator whose robot hangs in the riser on its rear clamp alone, at 2.9 s."""
    sim = Simulator(network or _riser(), ROBOT, start_m=1.5)
    for joint in ("bend_3_joint", "bend_4_joint"):
        sim.model.command(MotorCommand(joint, ControlMode.TORQUE, 0.7))
    sim.advance_to(2.9)
    truth = sim.truth()
    assert truth.halves[Half.REAR].clamped and not truth.halves[Half.FRONT].clamped
    return sim


def _rear_let_go(sim: Simulator, start_s: float, end_s: float) -> bool:
    """Whether the rear half was unclamped after some step from ``start_s`` to ``end_s``
    (looked at every 2 ms: no step's end is missed, however its time rounds)."""
    let_go = False
    for k in range(round((end_s - start_s) / 0.002) + 1):
        sim.advance_to(start_s + k * 0.002)
        let_go = let_go or not sim.truth().halves[Half.REAR].clamped
    return let_go


# -- a fault shorter than the world's step ---------------------------------------------


def test_a_fault_shorter_than_a_step_still_happens() -> None:
    # board_reset:26@3s+1ms started and ended in the same 10 ms step: the events said
    # 'start board_reset 26', 'end board_reset 26', and the board was never missed -
    # the clamp it holds never let go, a robot hanging on it never slipped
    sim = _hanging_on_the_rear_clamp()
    sim.schedule("board_reset:26@3s+1ms")
    assert _rear_let_go(sim, 3.0, 3.1)  # the board was down a step, its clamp off
    sim.advance_to(3.5)
    assert sim.truth().halves[Half.REAR].clamped  # back, as the bridge hands it its clamp
    counters = sim.counters()
    assert dict(counters.violations) == {"sliding": 1}
    assert 0 < counters.slide_m < 0.01
    # the same for a link loss of a microsecond: a frame the host writes then is lost
    sim.schedule("link_loss@3.6s+1us")
    lost = 0
    for k in range(20):  # a frame written after each step of 3.6 s to 3.64 s
        sim.advance_to(3.6 + k * 0.002)
        sim.write(b"\x01\x02\x03\x00")
        lost = sim.counters().frames_dropped
    assert lost >= 1
    assert [e.detail for e in sim.events() if e.kind == "fault"] == [
        "start board_reset 26",
        "end board_reset 26",
        "start link_loss",
        "end link_loss",
    ]


def test_a_network_file_s_fault_shorter_than_a_step_still_happens() -> None:
    network = _riser([{"kind": "board_fault", "target": "26", "at": "3 s", "duration": "2 ms"}])
    sim = _hanging_on_the_rear_clamp(network)
    assert _rear_let_go(sim, 3.0, 3.1)
    sim.advance_to(3.5)
    assert sim.truth().halves[Half.REAR].clamped
    assert dict(sim.counters().violations) == {"sliding": 1}


# -- the scripted drive's arguments -------------------------------------------------------


@pytest.mark.parametrize(
    ("argument", "value", "error", "words"),
    [
        # ZeroDivisionError: float division by zero, in the first drive_to
        ("speed_mps", 0.0, ArgumentValueError, "speed_mps: 0.0 is not a number of m/s above 0"),
        # ValueError: a clock cannot go back (-18.3 s)
        ("speed_mps", -0.08, ArgumentValueError, "speed_mps: -0.08 is not"),
        # taken: run_path() 'drove' the network and the robot never moved from 0.515 m
        ("speed_mps", math.nan, ArgumentValueError, "speed_mps: nan is not"),
        # taken: waited a tenth of the time its wheels needed, stopped 0.6 m in
        ("speed_mps", 10.0, ArgumentValueError, "and at most 0.1"),
        # TypeError: must be real number, not str
        ("speed_mps", "80 mm/s", ArgumentTypeError, "speed_mps: give a number of m/s, not a str"),
        # ValueError: cannot convert float NaN to integer, at the link's first clamp
        ("clamp_torque_nm", math.nan, ArgumentValueError, "clamp_torque_nm: nan is not"),
        # taken: steered to inf and stuck at every bend
        ("steer_rad", math.inf, ArgumentValueError, "steer_rad: inf is not"),
    ],
)
def test_a_scripted_drive_refuses_an_amount_it_cannot_drive_naming_it(
    argument: str, value: object, error: type[Exception], words: str
) -> None:
    with Simulator("bend-right", ROBOT) as sim:
        with pytest.raises(error) as refused:
            ScriptedDrive(sim, ModelSink(sim), **{argument: value})  # type: ignore[arg-type]
        assert words in str(refused.value)
        assert "\n" not in str(refused.value)
        assert sim.truth().front_m == sim.model.length_m  # nothing was sent


def test_a_scripted_drive_refuses_what_is_no_simulator_or_sink() -> None:
    with Simulator("straight", ROBOT) as sim:
        with pytest.raises(ArgumentTypeError, match=r"^sim: give a Simulator, not a str$"):
            ScriptedDrive("straight", ModelSink(sim))  # type: ignore[arg-type]
        with pytest.raises(ArgumentTypeError, match=r"^sink: give a CommandSink"):
            ScriptedDrive(sim, sim)  # type: ignore[arg-type]
        ScriptedDrive(sim, ModelSink(sim), speed_mps=0.1, steer_rad=math.pi)  # the limits


# -- what frames_dropped counts ----------------------------------------------------------


def test_a_request_for_a_rebooting_board_is_rejected_not_dropped() -> None:
    # docs/simulator.md and SimCounters said frames_dropped counted the frames 'lost to
    # link loss or a rebooting board': the bridge NACKs such a request (BUS_ERROR), a
    # rejected frame, and nothing but a link loss drops one
    codec = FrameCodec.for_robot(ROBOT)
    with Simulator("straight", ROBOT, faults="board_reset:22@1s") as sim:
        sim.write(codec.encode(Hello(1, codec.layout.digest)))
        sim.write(codec.encode(EStopReset(2)))
        sim.advance_to(1.1)
        sim.write(codec.encode(Setpoint(3, 22, 1, ControlMode.VELOCITY, 0)))  # bend_1_drive
        counters = sim.counters()
        assert (counters.frames_rejected, counters.frames_dropped) == (1, 0)
    page = (Path(__file__).parent.parent / "docs" / "simulator.md").read_text(encoding="utf-8")
    said = page[page.index("`frames_dropped` (") :].split(")", 1)[0]
    assert "link_loss" in said and "board_reset" in said and "rejected" in said
    assert SimCounters.__doc__ is not None
    assert "resetting board." not in SimCounters.__doc__


# -- where a slide stops -----------------------------------------------------------------


def test_a_slide_down_a_riser_stops_at_its_foot_as_the_page_says() -> None:
    # docs/simulator.md said a slide 'only stops at the path's ends': down riser.yaml's
    # riser it stops where the rotational module's slope is gentle, across the foot bend
    with Simulator("riser", ROBOT, start_m=3.5) as sim:
        for joint in ("bend_3_joint", "bend_4_joint"):
            sim.model.command(MotorCommand(joint, ControlMode.TORQUE, 0.7))
        sim.advance_to(3.0)
        sim.schedule("board_fault:26@3s")  # the rear clamp's power off, for good
        sim.advance_to(20.0)
        truth = sim.truth()
        assert not truth.sliding and truth.velocity_mps == 0.0
        assert sim.model.length_m < truth.front_m < sim.model.path.length_m
        assert truth.module_segment["front"] == "riser"
        assert truth.module_segment["rotational"] == "foot"
        assert dict(sim.counters().violations) == {"sliding": 1}
    page = (Path(__file__).parent.parent / "docs" / "simulator.md").read_text(encoding="utf-8")
    assert "it only stops at the path's ends" not in page
    assert "at the foot of `riser.yaml`'s riser it lies across the" in page


# -- a slide names its cause -------------------------------------------------------------


def _slide(sim: Simulator) -> str:
    return next(e.detail for e in sim.events() if e.detail.startswith("sliding:"))


def test_a_slide_names_the_joints_that_let_go_and_why() -> None:
    # a slide's violation said 'sliding: unclamped on a 90 deg slope' whatever let go: a
    # clamp board's power cut, a clamp too weak, a clamp released
    sim = _hanging_on_the_rear_clamp()
    sim.schedule("board_fault:26@3s+0.5s")  # bend_3's H-bridge off: its joint goes limp
    sim.advance_to(4.0)
    assert _slide(sim) == (
        "sliding: unclamped on a 90 deg slope (front: bend_1_joint unpowered at 0.0 deg,"
        " bend_2_joint unpowered at 0.0 deg; rear: bend_3_joint unpowered at 83.1 deg)"
    )
    sim = _hanging_on_the_rear_clamp()
    sim.model.command(MotorCommand("bend_4_joint", ControlMode.TORQUE, 0.2))  # too weak
    sim.model.command(MotorCommand("bend_1_joint", ControlMode.POSITION, 0.0))
    sim.model.command(MotorCommand("bend_2_joint", ControlMode.POSITION, 0.0))
    sim.advance_to(3.5)
    assert _slide(sim).endswith(
        "(front: bend_1_joint free of the wall at 0.0 deg, bend_2_joint free of the wall"
        " at 0.0 deg; rear: bend_4_joint presses 0.20 N*m (a clamp needs 0.35))"
    )


# -- one FaultSpec ---------------------------------------------------------------------


def test_one_fault_spec_is_one_fault() -> None:
    # Simulator(faults=FaultSpec(...)) and sim.schedule(FaultSpec(...)) were refused as
    # 'a fault is text ... or a FaultSpec, not ('kind', 'board_reset')': the spec was
    # iterated field by field, as a text once was character by character
    spec = FaultSpec(kind="board_reset", at=1.0, target="22")
    with Simulator("straight", ROBOT, faults=spec) as sim:
        sim.schedule(FaultSpec(kind="link_loss", at=2.6, duration=0.2))
        sim.advance_to(3.0)
        assert [e.detail for e in sim.events() if e.kind == "fault"] == [
            "start board_reset 22",
            "end board_reset 22",
            "start link_loss",
            "end link_loss",
        ]


def test_the_api_names_a_fault_spec_given_for_fault_text() -> None:
    # split_faults (simulate_tree's faults=) said 'faults: each item is text, not a tuple'
    # for one FaultSpec: it was read field by field
    with pytest.raises(InputError) as refused:
        split_faults(FaultSpec(kind="board_reset", at=1.0, target="22"))
    assert str(refused.value).endswith("not a FaultSpec (write it as text: 'board_reset:22@1s')")
    with pytest.raises(InputError, match=r"each item is text, not a FaultSpec \(write it"):
        split_faults([FaultSpec(kind="link_loss", at=1.5, duration=0.25)])
    assert split_faults("link_loss@1.5s+0.25s") == (["link_loss@1.5s+0.25s"], None)


# -- one board, two spellings ------------------------------------------------------------


def test_two_resets_of_one_board_by_two_spellings_are_one_fault() -> None:
    # '026' is board 26 (it is taken as such), but board_reset:026@3.2s over
    # board_reset:26@3s+2s was another fault: its end, at 4.7 s, brought board 26 back
    # while the first reset still ran to 5 s (the events said 'end board_reset 026')
    sim = _hanging_on_the_rear_clamp()
    sim.schedule(["board_reset:26@3s+2s", "board_reset:026@3.2s"])  # to 5 s, to 4.7 s
    sim.advance_to(4.9)
    assert not sim.truth().halves[Half.REAR].clamped  # board 26 still down
    sim.advance_to(5.1)
    assert sim.truth().halves[Half.REAR].clamped
    assert [e.detail for e in sim.events() if e.kind == "fault"] == [
        "start board_reset 26",
        "start board_reset 26",
        "end board_reset 26",
        "end board_reset 26",
    ]


# -- the end state of a robot that fell --------------------------------------------------


def test_the_end_state_says_the_robot_slid_before_it_came_to_rest() -> None:
    # pirate-bt sim's end state said 'robot at rest' of a robot that had slid 2.2 m
    # down the riser when its clamp's power went off and lay at its foot
    with Simulator("riser", ROBOT, start_m=3.5) as sim:
        for joint in ("bend_3_joint", "bend_4_joint"):
            sim.model.command(MotorCommand(joint, ControlMode.TORQUE, 0.7))
        sim.advance_to(3.0)
        assert end_state(sim).startswith("end state: robot at rest, drives stopped;")
        sim.schedule("board_fault:26@3s")
        sim.advance_to(20.0)
        assert end_state(sim).startswith(
            "end state: robot at rest after sliding 2.23 m with no half holding it (1 slide),"
            " drives stopped; front half not clamped, rear half not clamped;"
        )


@pytest.mark.parametrize("step", ["drive_to", "bend", "rotate"])
def test_a_scripted_step_to_nowhere_is_refused_and_the_clock_kept(step: str) -> None:
    # drive_to(nan) advanced the shared clock by nan seconds: sim.clock.now() read nan
    # from then on, and the world never stepped again
    with Simulator("straight", ROBOT) as sim:
        drive = ScriptedDrive(sim, ModelSink(sim))
        drive.start()
        now = sim.clock.now()
        args: tuple[object, ...] = (math.nan,) if step != "bend" else (Half.FRONT, math.nan)
        with pytest.raises(ArgumentValueError, match=r"is not a finite number of"):
            getattr(drive, step)(*args)
        assert sim.clock.now() == now
        drive.drive_to(1.0)  # the world goes on
        assert abs(sim.truth().front_m - 1.0) < 0.01


@pytest.mark.parametrize(
    "faults",
    [
        ["board_fault:26@3s+0.5s", "board_reset:26@3.2s"],  # the fault ends first
        ["board_reset:26@3.2s", "board_fault:26@3.3s+0.2s"],  # a fault inside the reset
    ],
    ids=["fault-then-reset", "fault-inside-reset"],
)
def test_a_board_fault_that_ends_during_a_reset_brings_nothing_back_early(
    faults: list[str],
) -> None:
    # board_fault:26@3s+0.5s with board_reset:26@3.2s drove the rear clamp again from
    # 3.5 s, while board 26 was down until 4.7 s: the fault's end commanded the
    # setpoints it held, rebooting board or not
    sim = _hanging_on_the_rear_clamp()
    sim.schedule(faults)
    sim.advance_to(4.6)
    assert not sim.truth().halves[Half.REAR].clamped  # board 26 still rebooting
    sim.advance_to(5.2)
    assert sim.truth().halves[Half.REAR].clamped  # back with the reset's end
