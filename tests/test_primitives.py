"""Motion primitives against the real supervisor over a fake robot port.

The fake port (``pirate_bt.safety.testing.FakePort``) either applies setpoints at
once (``physics=True``) or holds whatever the test sets, so each primitive's
success, refusal, timeout, stall and terminate paths can be stepped tick by tick.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import py_trees
import pytest
from py_trees.common import Status

from pirate_bt.behaviours.base import BuildContext, NoParams
from pirate_bt.behaviours.basic import Success
from pirate_bt.behaviours.primitives import (
    AlignRoll,
    AlignRollParams,
    Bend,
    BendParams,
    Clamp,
    ClampParams,
    Confirm,
    ConfirmParams,
    Drive,
    DriveParams,
    MoveFrontClear,
    MoveFrontClearParams,
    Primitive,
    Rotate,
    RotateParams,
    SafeState,
    SafeStateParams,
    Unclamp,
    UnclampParams,
)
from pirate_bt.clock import SimClock
from pirate_bt.errors import ConfigurationError
from pirate_bt.robot import Half, load_robot
from pirate_bt.robot.commands import ControlMode
from pirate_bt.safety import Mode, Supervisor
from pirate_bt.safety.testing import FakePort
from pirate_bt.treefile.registry import default_registry

ROBOT = load_robot()
DT = 0.05


@pytest.fixture(autouse=True)
def clean_blackboard() -> None:
    py_trees.blackboard.Blackboard.clear()


class Rig:
    """A clock, a fake port and a supervisor, with helpers to step a node."""

    def __init__(self, physics: bool = True, mode: Mode = Mode.AUTONOMOUS) -> None:
        self.clock = SimClock(1.0)
        self.port = FakePort(ROBOT, self.clock, physics=physics)
        self.supervisor = Supervisor(self.port, self.clock, mode=mode)
        self.context = BuildContext(robot=ROBOT, clock=self.clock, supervisor=self.supervisor)

    def node(self, cls: Any, params: Any, name: str = "node") -> Any:
        node = cls.from_params(name, params, self.context)
        node.setup()
        return node

    def run(self, node: py_trees.behaviour.Behaviour, ticks: int = 400) -> Status:
        for _ in range(ticks):
            self.supervisor.tick()
            node.tick_once()
            if node.status != Status.RUNNING:
                return node.status
            self.clock.advance(DT)
        return node.status


def both_clamped(rig: Rig) -> None:
    rig.port.clamp_half(Half.REAR, 0.7)
    rig.port.clamp_half(Half.FRONT, 0.7)


# -- registry and load-time limits --------------------------------------------------


def test_every_primitive_is_registered() -> None:
    registry = default_registry()
    for name in (
        "clamp",
        "unclamp",
        "drive",
        "bend",
        "rotate",
        "align_roll",
        "move_front_clear",
        "confirm",
        "safe_state",
    ):
        cls = registry.get(name)
        assert cls.needs_robot


def test_params_take_units() -> None:
    p = ClampParams.model_validate({"half": "front", "torque": "0.5 N*m"})
    assert p.torque == pytest.approx(0.5)
    d = DriveParams.model_validate({"velocity": "80 mm/s", "distance": "1.5 m", "timeout": "10 s"})
    assert (d.velocity, d.distance, d.timeout) == pytest.approx((0.08, 1.5, 10.0))
    b = BendParams.model_validate({"module": "bend_1", "angle": "90 deg"})
    assert b.angle == pytest.approx(math.pi / 2)


@pytest.mark.parametrize(
    ("cls", "params", "field"),
    [
        (Clamp, ClampParams(half=Half.FRONT, torque=0.1), "torque"),
        (Clamp, ClampParams(half=Half.FRONT, torque=2.0), "torque"),
        (Bend, BendParams(module="bend_1", angle=math.radians(150)), "angle"),
        (Bend, BendParams(module="rotational", angle=0.1), "module"),
        (Rotate, RotateParams(angle=math.radians(200)), "angle"),
        (Drive, DriveParams(velocity=0.5, distance=1.0), "velocity"),
        (Drive, DriveParams(velocity=0.08), "distance"),
        (
            Drive,
            DriveParams(velocity=0.08, distance=1.0, stop_when_turned=True),
            "stop_when_turned",
        ),
    ],
)
def test_check_limits(cls: Any, params: Any, field: str) -> None:
    problems = cls.check_limits(params, ROBOT)
    assert problems and problems[0].startswith(f"{field}:")


def test_limits_pass_for_sane_params() -> None:
    assert Clamp.check_limits(ClampParams(half=Half.REAR, torque=0.7), ROBOT) == []
    assert Bend.check_limits(BendParams(module="front", angle=0.7, sign_from="s"), ROBOT) == []
    assert Drive.check_limits(DriveParams(velocity=-0.08, distance=0.5), ROBOT) == []


def test_setup_without_robot_fails_clearly() -> None:
    node = Clamp.from_params("c", ClampParams(half=Half.REAR, torque=0.5), BuildContext())
    with pytest.raises(ConfigurationError, match="needs a robot"):
        node.setup()


# -- clamp / unclamp ----------------------------------------------------------------


def test_clamp_succeeds_when_springs_read_the_force() -> None:
    rig = Rig()
    node = rig.node(Clamp, ClampParams(half=Half.REAR, torque=0.7))
    assert rig.run(node) == Status.SUCCESS
    assert rig.supervisor.half_states()[Half.REAR].value == "clamped"


def test_front_clamp_refused_until_front_module_clear() -> None:
    rig = Rig()
    rig.port.set_tilt(0.0)
    rig.port.clamp_half(Half.REAR, 0.7)
    node = rig.node(Clamp, ClampParams(half=Half.FRONT, torque=0.7))
    assert rig.run(node) == Status.FAILURE
    assert "refused clamp(front" in node.feedback_message
    assert "front_not_clear" in node.feedback_message
    clear = rig.node(MoveFrontClear, MoveFrontClearParams())
    assert rig.run(clear) == Status.SUCCESS
    again = rig.node(Clamp, ClampParams(half=Half.FRONT, torque=0.7))
    assert rig.run(again) == Status.SUCCESS


def test_clamp_times_out_without_feedback() -> None:
    rig = Rig(physics=False)
    node = rig.node(Clamp, ClampParams(half=Half.REAR, torque=0.7, timeout=1.0))
    assert rig.run(node) == Status.FAILURE
    assert node.feedback_message.startswith("timeout:")
    assert rig.clock.now() == pytest.approx(2.05, abs=0.11)


def test_clamp_over_an_opening_fails_at_once() -> None:
    rig = Rig(physics=False)
    rig.port.set(bend_3_angle=math.radians(110), bend_4_angle=math.radians(110))
    node = rig.node(Clamp, ClampParams(half=Half.REAR, torque=0.7))
    assert rig.run(node) == Status.FAILURE
    assert node.feedback_message.startswith("no wall")


def test_unclamp_needs_the_other_half_and_then_succeeds() -> None:
    rig = Rig()
    rig.port.clamp_half(Half.FRONT, 0.7)
    node = rig.node(Unclamp, UnclampParams(half=Half.FRONT))
    assert rig.run(node) == Status.FAILURE
    assert "other_half_not_clamped" in node.feedback_message
    rig.port.clamp_half(Half.REAR, 0.7)
    node = rig.node(Unclamp, UnclampParams(half=Half.FRONT))
    assert rig.run(node) == Status.SUCCESS
    assert all(abs(rig.port.values[f"bend_{i}_angle"]) < 0.05 for i in (1, 2))


def test_an_unclamp_that_times_out_shows_the_spring_still_pressing() -> None:
    # the joints came back straight, but bend_1's spring still reads force (a stuck
    # sensor, something caught): the timeout says so, not just the angles
    rig = Rig()
    both_clamped(rig)
    node = rig.node(Unclamp, UnclampParams(half=Half.FRONT, timeout=1.0))
    for _ in range(100):
        rig.supervisor.tick()
        node.tick_once()
        if node.status != Status.RUNNING:
            break
        rig.port.set(bend_1_spring=6.0)
        rig.clock.advance(DT)
    assert node.status == Status.FAILURE
    assert node.feedback_message.startswith("timeout: not done after 1 s (releasing front:")
    assert "bend_1 0.0° 6.0 N" in node.feedback_message, node.feedback_message
    assert "bend_2 0.0° 0.0 N" in node.feedback_message, node.feedback_message


# -- bend / rotate / align ---------------------------------------------------------------


def test_bend_a_half_with_a_sign_from_the_blackboard() -> None:
    rig = Rig()
    rig.port.clamp_half(Half.REAR, 0.7)
    py_trees.blackboard.Blackboard.set("/steer_sign", -1)
    node = rig.node(
        Bend, BendParams(module="front", angle=math.radians(40), sign_from="steer_sign")
    )
    assert rig.run(node) == Status.SUCCESS
    for i in (1, 2):
        assert rig.port.values[f"bend_{i}_angle"] == pytest.approx(math.radians(-40), abs=0.05)


def test_bend_fails_on_a_bad_sign() -> None:
    rig = Rig()
    rig.port.clamp_half(Half.REAR, 0.7)
    py_trees.blackboard.Blackboard.set("/steer_sign", 3)
    node = rig.node(Bend, BendParams(module="bend_1", angle=0.7, sign_from="steer_sign"))
    assert rig.run(node) == Status.FAILURE
    assert "not +1 or -1" in node.feedback_message


def test_rotate_refused_with_both_halves_clamped() -> None:
    rig = Rig()
    both_clamped(rig)
    node = rig.node(Rotate, RotateParams(angle=math.radians(45)))
    assert rig.run(node) == Status.FAILURE
    assert "rotate_needs_one_clamped" in node.feedback_message


def test_rotate_succeeds_with_one_half_clamped() -> None:
    rig = Rig()
    rig.port.clamp_half(Half.REAR, 0.7)
    node = rig.node(Rotate, RotateParams(angle=math.radians(45)))
    assert rig.run(node) == Status.SUCCESS
    assert rig.port.values["rotation_angle"] == pytest.approx(math.radians(45), abs=0.05)


@pytest.mark.parametrize(
    ("roll_deg", "imu_deg", "rotation_deg", "sign"),
    [(90, 0, 90, 1), (-90, 0, -90, 1), (180, 0, 0, -1), (0, 0, 0, 1), (90, 30, 60, 1)],
)
def test_align_roll_picks_the_smaller_rotation(
    roll_deg: float, imu_deg: float, rotation_deg: float, sign: int
) -> None:
    rig = Rig()
    rig.port.clamp_half(Half.REAR, 0.7)
    rig.port.set(imu__roll=math.radians(imu_deg))
    node = rig.node(AlignRoll, AlignRollParams(roll=math.radians(roll_deg)))
    assert rig.run(node) == Status.SUCCESS
    assert rig.port.values["rotation_angle"] == pytest.approx(math.radians(rotation_deg), abs=0.05)
    assert py_trees.blackboard.Blackboard.get("/steer_sign") == sign


@pytest.mark.parametrize(
    ("roll_deg", "imu_deg", "rotation_before_deg", "rotation_deg", "sign"),
    [
        # after the forward bend PAB both halves lie on the turn's roll (or roll + 180)
        (90, 90, 0, 0, 1),
        (180, 0, 0, 0, -1),
        (-90, 90, 0, 0, -1),
        # the rear half must turn: rotating by +d turns it by -d (the front holds)
        (90, 0, 90, 0, 1),
        (90, 30, 0, -60, 1),
        (0, -20, 50, 30, 1),
    ],
)
def test_align_roll_of_the_rear_half_rotates_against_the_clamped_front(
    roll_deg: float, imu_deg: float, rotation_before_deg: float, rotation_deg: float, sign: int
) -> None:
    rig = Rig()
    rig.port.clamp_half(Half.FRONT, 0.7)
    rig.port.set(imu__roll=math.radians(imu_deg), rotation_angle=math.radians(rotation_before_deg))
    node = rig.node(AlignRoll, AlignRollParams(roll=math.radians(roll_deg), half=Half.REAR))
    assert rig.run(node) == Status.SUCCESS
    assert rig.port.values["rotation_angle"] == pytest.approx(math.radians(rotation_deg), abs=0.05)
    assert py_trees.blackboard.Blackboard.get("/steer_sign") == sign


def test_align_roll_of_the_rear_half_needs_the_rotation_reading() -> None:
    rig = Rig()
    rig.port.clamp_half(Half.FRONT, 0.7)
    node = rig.node(AlignRoll, AlignRollParams(roll=0.0, half=Half.REAR))
    rig.supervisor.tick()
    state = rig.supervisor.state()
    assert node._choose(dataclasses.replace(state, rotation_rad=None)) is not None
    assert "no rotation reading" in node._choose(dataclasses.replace(state, rotation_rad=None))


def test_position_commands_are_resent_until_unclipped() -> None:
    rig = Rig(physics=False)
    rig.port.clamp_half(Half.REAR, 0.7)
    node = rig.node(Rotate, RotateParams(angle=math.radians(90), timeout=0.5))
    for _ in range(6):  # the joint follows each setpoint a tick later, as a free one does
        # (one that did not move would be stopped by the supervisor's stall watch, 1dc308e)
        rig.run(node, ticks=1)
        told = [c.value for c in rig.port.sent if c.motor == "rotate"]
        if told:
            rig.port.set(rotation_angle=told[-1])
    sent = [c.value for c in rig.port.sent if c.motor == "rotate"]
    assert len(sent) >= 5 and sent == sorted(sent) and sent[-1] < math.radians(90)


# -- drive -----------------------------------------------------------------------


def drive_rig() -> Rig:
    rig = Rig()
    both_clamped(rig)
    return rig


def test_drive_a_distance_then_stop() -> None:
    rig = drive_rig()
    node = rig.node(Drive, DriveParams(velocity=0.08, distance=0.4))
    assert rig.run(node) == Status.SUCCESS
    assert rig.clock.now() - 1.0 == pytest.approx(0.4 / 0.08, rel=0.1)
    last = rig.port.batches[-1]
    assert all(c.mode is ControlMode.VELOCITY and c.value == 0.0 for c in last)


def test_drive_refused_while_a_half_transitions() -> None:
    rig = Rig()
    rig.port.clamp_half(Half.REAR, 0.7)
    rig.port.half_between(Half.FRONT)
    node = rig.node(Drive, DriveParams(velocity=0.08, distance=0.4))
    assert rig.run(node) == Status.FAILURE
    assert "half_transitioning" in node.feedback_message


def test_drive_fails_on_a_stalled_motor() -> None:
    rig = drive_rig()
    node = rig.node(Drive, DriveParams(velocity=0.08, distance=2.0))
    rig.run(node, ticks=10)
    rig.port.set(bend_3_drive__current=1.5, bend_3_drive__velocity=0.0)
    original = rig.port._apply

    def stalled(batch: Any) -> None:
        original(batch)
        rig.port.set(bend_3_drive__velocity=0.0)

    rig.port._apply = stalled  # type: ignore[method-assign]
    assert rig.run(node) == Status.FAILURE
    assert node.feedback_message.startswith("stall: bend_3_drive")


def blocked(rig: Rig) -> None:
    # As on the simulator: held by the pipe, every wheel stands at stall current.
    for m in ROBOT.drive_motors():
        rig.port.set(**{f"{m.name}__current": 1.5, f"{m.name}__velocity": 0.0})


def test_heavy_load_at_speed_is_not_blocked() -> None:
    # A long tether up a riser: nearly stall current, but the robot climbs at speed.
    rig = drive_rig()
    node = rig.node(Drive, DriveParams(velocity=0.08, distance=0.4))
    rig.run(node, ticks=5)
    rig.port.set(**{f"{m.name}__current": 1.35 for m in ROBOT.drive_motors()})
    assert rig.run(node) == Status.SUCCESS
    until = rig.node(Drive, DriveParams(velocity=0.08, until="blocked", max_distance=0.3))
    rig.run(until, ticks=5)
    rig.port.set(**{f"{m.name}__current": 1.35 for m in ROBOT.drive_motors()})
    assert rig.run(until) == Status.FAILURE
    assert "no feature (blocked) within 0.3 m" in until.feedback_message


def test_drive_until_blocked_succeeds_when_every_wheel_pushes() -> None:
    rig = drive_rig()
    node = rig.node(Drive, DriveParams(velocity=0.08, until="blocked"))
    rig.run(node, ticks=10)
    assert node.status == Status.RUNNING
    blocked(rig)
    assert rig.run(node) == Status.SUCCESS


def test_drive_a_distance_fails_when_blocked() -> None:
    rig = drive_rig()
    node = rig.node(Drive, DriveParams(velocity=0.08, distance=2.0))
    rig.run(node, ticks=10)
    blocked(rig)
    assert rig.run(node) == Status.FAILURE
    assert node.feedback_message.startswith("blocked")


def test_drive_until_a_feature_gives_up_after_max_distance() -> None:
    rig = drive_rig()
    node = rig.node(Drive, DriveParams(velocity=0.08, until="blocked", max_distance=0.2))
    assert rig.run(node) == Status.FAILURE
    assert "no feature (blocked) within 0.2 m" in node.feedback_message


def test_drive_until_opening_passed() -> None:
    rig = drive_rig()
    node = rig.node(Drive, DriveParams(velocity=0.08, until="opening_passed"))
    rig.run(node, ticks=10)
    # the opening passes under bend_3, then under bend_4
    for module in ("bend_3", "bend_4"):
        rig.port.set(**{f"{module}_angle": math.radians(110), f"{module}_spring": 0.0})
        rig.run(node, ticks=5)
        assert node.status == Status.RUNNING
        rig.port.clamp_half(Half.REAR, 0.7)
        rig.run(node, ticks=5)
    assert node.status == Status.SUCCESS


def test_drive_until_opening_passed_waits_until_the_joint_is_back_at_the_wall() -> None:
    rig = drive_rig()
    node = rig.node(Drive, DriveParams(velocity=0.08, until="opening_passed"))
    rig.run(node, ticks=10)
    for module in ("bend_3", "bend_4"):
        rig.port.set(**{f"{module}_angle": math.radians(110), f"{module}_spring": 0.0})
        rig.run(node, ticks=5)
        # swinging back, below the off-wall threshold but not at the wall yet: the
        # module may still be at the edge of the opening
        rig.port.set(**{f"{module}_angle": math.radians(100)})
        rig.run(node, ticks=5)
        assert node.status == Status.RUNNING
        rig.port.clamp_half(Half.REAR, 0.7)
        rig.run(node, ticks=5)
    assert node.status == Status.SUCCESS


def test_interrupted_drive_stops_the_wheels() -> None:
    rig = drive_rig()
    node = rig.node(Drive, DriveParams(velocity=0.08, distance=2.0))
    rig.run(node, ticks=10)
    assert rig.port.values["bend_1_drive.velocity"] > 0
    node.stop(Status.INVALID)
    assert all(rig.port.values[f"{m.name}.velocity"] == 0.0 for m in ROBOT.drive_motors())


def test_interrupted_joint_primitive_leaves_clamps_alone() -> None:
    rig = Rig()
    rig.port.clamp_half(Half.REAR, 0.7)
    node = rig.node(Bend, BendParams(module="front", angle=0.7))
    rig.run(node, ticks=2)
    sent = len(rig.port.sent)
    node.stop(Status.INVALID)
    assert all(c.mode is ControlMode.VELOCITY for c in rig.port.sent[sent:])
    assert rig.supervisor.half_states()[Half.REAR].value == "clamped"


# -- confirmation and safe state ------------------------------------------------


def confirmed(rig: Rig) -> Confirm:
    child = rig.node(Clamp, ClampParams(half=Half.REAR, torque=0.7), name="clamp")
    node = Confirm.from_params("confirm", ConfirmParams(step="clamp rear"), rig.context, child)
    assert isinstance(node, Confirm)
    return node


def test_confirmation_holds_in_supervised_mode_until_confirmed() -> None:
    rig = Rig(mode=Mode.SUPERVISED)
    node = confirmed(rig)
    assert rig.run(node, ticks=20) == Status.RUNNING
    assert rig.port.sent == []
    assert rig.supervisor.pending_confirmations() == ["clamp rear"]
    rig.supervisor.confirm("clamp rear")
    assert rig.run(node) == Status.SUCCESS
    assert rig.supervisor.pending_confirmations() == []
    # the grant ends with the step
    late = rig.node(Clamp, ClampParams(half=Half.FRONT, torque=0.7))
    assert rig.run(late) == Status.FAILURE
    assert "not_confirmed" in late.feedback_message


def test_denied_confirmation_fails() -> None:
    rig = Rig(mode=Mode.SUPERVISED)
    node = confirmed(rig)
    rig.run(node, ticks=3)
    rig.supervisor.deny("clamp rear")
    assert rig.run(node) == Status.FAILURE
    assert "denied" in node.feedback_message


def test_confirmation_is_immediate_in_autonomous_mode() -> None:
    rig = Rig()
    assert rig.run(confirmed(rig)) == Status.SUCCESS


def test_safe_state_carries_the_reason_of_the_failed_primitive() -> None:
    rig = Rig()
    rig.port.set_tilt(0.0)
    rig.port.clamp_half(Half.REAR, 0.7)
    failing = rig.node(Clamp, ClampParams(half=Half.FRONT, torque=0.7), name="clamp front")
    main = py_trees.composites.Sequence("main", memory=True, children=[failing])
    recover = py_trees.composites.Sequence(
        "recover",
        memory=True,
        children=[
            SafeState.from_params("safe", SafeStateParams(reason="test PAB failed"), rig.context),
            Success.from_params("done", NoParams(), rig.context),
        ],
    )
    root = py_trees.composites.Selector("root", memory=True, children=[main, recover])
    assert rig.run(root) == Status.SUCCESS
    reason = rig.supervisor.safe_state_reason
    assert reason is not None
    assert reason.startswith("test PAB failed: clamp front: refused clamp(front")
    assert "front_not_clear" in reason


def test_primitive_base_is_abstract() -> None:
    assert issubclass(Clamp, Primitive)
    assert Primitive.outcomes(None) == frozenset({"success", "failure", "running"})


def test_drive_reverse_drives_backwards_at_the_speed() -> None:
    rig = drive_rig()
    node = rig.node(Drive, DriveParams(velocity=0.08, reverse=True, distance=0.2))
    assert rig.run(node) == Status.SUCCESS
    sent = [c.value for c in rig.port.sent if c.motor == "bend_1_drive" and c.value != 0.0]
    # ramped up by the acceleration limit, all of it backwards
    assert sent and all(v < 0 for v in sent) and sent[-1] == pytest.approx(-0.08)
    assert rig.clock.now() - 1.0 == pytest.approx(0.2 / 0.08, rel=0.1)


def test_drive_backwards_until_the_rear_half_is_over_an_opening() -> None:
    rig = drive_rig()
    node = rig.node(Drive, DriveParams(velocity=0.08, reverse=True, until="rear_opening"))
    rig.run(node, ticks=10)
    # a front joint off the wall is not what this drive looks for
    rig.port.set(bend_2_angle=math.radians(110), bend_2_spring=0.0)
    rig.run(node, ticks=5)
    assert node.status == Status.RUNNING
    rig.port.set(bend_4_angle=math.radians(110), bend_4_spring=0.0)
    assert rig.run(node) == Status.SUCCESS
    assert node.sensed == "rear_opening"


def test_drive_backwards_until_the_front_half_passed_an_opening() -> None:
    rig = drive_rig()
    params = DriveParams(velocity=0.08, reverse=True, until="front_opening_passed")
    node = rig.node(Drive, params)
    rig.run(node, ticks=10)
    # the opening passes under bend_2, then under bend_1
    for module in ("bend_2", "bend_1"):
        rig.port.set(**{f"{module}_angle": math.radians(110), f"{module}_spring": 0.0})
        rig.run(node, ticks=5)
        assert node.status == Status.RUNNING
        rig.port.clamp_half(Half.FRONT, 0.7)
        rig.run(node, ticks=5)
    assert node.status == Status.SUCCESS
    assert "front half passed an opening" in node.feedback_message


def test_stop_at_feature_looks_at_the_leading_half() -> None:
    for reverse, leading, trailing in ((False, "bend_1", "bend_4"), (True, "bend_4", "bend_1")):
        rig = drive_rig()
        params = DriveParams(velocity=0.08, reverse=reverse, distance=2.0, stop_at_feature=True)
        node = rig.node(Drive, params)
        rig.run(node, ticks=10)
        rig.port.set(**{f"{trailing}_angle": math.radians(110), f"{trailing}_spring": 0.0})
        rig.run(node, ticks=5)
        assert node.status == Status.RUNNING, reverse
        rig.port.set(**{f"{leading}_angle": math.radians(110), f"{leading}_spring": 0.0})
        assert rig.run(node) == Status.SUCCESS, reverse


def test_drive_until_the_front_half_is_over_an_opening() -> None:
    rig = drive_rig()
    node = rig.node(Drive, DriveParams(velocity=0.08, until="front_opening"))
    rig.run(node, ticks=10)
    assert node.status == Status.RUNNING
    rig.port.set(bend_1_angle=math.radians(110), bend_1_spring=0.0)
    assert rig.run(node) == Status.SUCCESS
