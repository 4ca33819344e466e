"""What each command means to the checks: its motor commands, the halves it clamps, releases
or presses, the readings it relies on.

Written with the mutation run (docs/testing.md). A check added with
``Supervisor.add_check`` reads the :class:`~pirate_bt.safety.checks.Intent` these tests
pin down; the supervisor-level tests show the refusals an operator sees when an intent
is wrong (a raw drive that ignores a half in transition, a clamp that swings joints off
the wall, a front joint pressed with the front module in the way).
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from pirate_bt.clock import SimClock
from pirate_bt.errors import ValidationFailed
from pirate_bt.robot import ControlMode, Half, MotorCommand, load_robot
from pirate_bt.safety import (
    Bend,
    Clamp,
    Drive,
    MoveFrontClear,
    Outcome,
    Raw,
    Reason,
    Rotate,
    Supervisor,
    Tilt,
    Unclamp,
)
from pirate_bt.safety.checks import CheckContext, Intent, Problem
from pirate_bt.safety.commands import Command
from pirate_bt.safety.expand import Expander
from pirate_bt.safety.testing import FakePort

ROBOT = load_robot()
EXPANDER = Expander(ROBOT)
BASE = EXPANDER.base_channels
TOL = ROBOT.safety.angle_tolerance
WALL = min(p.angle for p in ROBOT.clamp.contact_angles)
# MoveFrontClear's target: past the clear angle by the angle tolerance
CLEAR = ROBOT.clamp.front_clear_angle + ROBOT.safety.angle_tolerance


@pytest.fixture
def clock() -> SimClock:
    return SimClock(100.0)


@pytest.fixture
def port(clock: SimClock) -> FakePort:
    return FakePort(ROBOT, clock)


@pytest.fixture
def sup(port: FakePort, clock: SimClock) -> Supervisor:
    return Supervisor(port, clock)


def intent(command: Command, port: FakePort | None = None) -> Intent:
    state = port.state() if port is not None else FakePort(ROBOT, SimClock()).state()
    out = EXPANDER.expand(command, state)
    assert isinstance(out, Intent), out
    return out


def problem(command: Command) -> Problem:
    out = EXPANDER.expand(command, FakePort(ROBOT, SimClock()).state())
    assert isinstance(out, Problem), out
    return out


def raw(motor: str, mode: ControlMode, value: float) -> Raw:
    return Raw(MotorCommand(motor, mode, value))


# -- the intent a check sees ----------------------------------------------------------------


COMMANDS: list[Command] = [
    Clamp(Half.REAR, 0.5),
    Unclamp(Half.FRONT),
    Bend("bend_2", 0.3),
    Rotate(0.1),
    Tilt(0.5),
    MoveFrontClear(),
    Drive(0.02),
    Drive(0.0),
    raw("bend_1_joint", ControlMode.TORQUE, 0.5),
    raw("bend_1_joint", ControlMode.POSITION, 0.2),
    raw("bend_1_drive", ControlMode.VELOCITY, 0.02),
    raw("rotate", ControlMode.POSITION, 0.1),
    raw("front_tilt", ControlMode.POSITION, 1.2),
    raw("front_leds", ControlMode.PWM, 0.5),
]


@pytest.mark.parametrize("command", COMMANDS, ids=str)
def test_an_intent_carries_the_command_it_came_from(command: Command) -> None:
    assert intent(command).command is command


def test_a_check_sees_the_intent_of_every_command_it_judges(
    sup: Supervisor, port: FakePort
) -> None:
    seen: list[Command] = []

    def record(ctx: CheckContext, it: Intent) -> Problem | None:
        seen.append(it.command)
        return None

    sup.add_check(record)
    port.clamp_half(Half.REAR)
    for command in (Drive(0.02), Rotate(0.05), Unclamp(Half.FRONT)):
        assert sup.command(command).ok
    assert seen == [Drive(0.02), Rotate(0.05), Unclamp(Half.FRONT)]


def test_the_motor_commands_of_each_command() -> None:
    assert intent(Clamp(Half.REAR, 0.5)).motor_commands == (
        MotorCommand("bend_3_joint", ControlMode.TORQUE, 0.5),
        MotorCommand("bend_4_joint", ControlMode.TORQUE, 0.5),
    )
    assert intent(Unclamp(Half.FRONT, 0.2)).motor_commands == (
        MotorCommand("bend_1_joint", ControlMode.POSITION, 0.2),
        MotorCommand("bend_2_joint", ControlMode.POSITION, 0.2),
    )
    assert intent(Bend("bend_4", -0.3)).motor_commands == (
        MotorCommand("bend_4_joint", ControlMode.POSITION, -0.3),
    )
    assert intent(Rotate(0.1)).motor_commands == (
        MotorCommand("rotate", ControlMode.POSITION, 0.1),
    )
    assert intent(Tilt(0.5)).motor_commands == (
        MotorCommand("front_tilt", ControlMode.POSITION, 0.5),
    )
    drives = intent(Drive(0.02)).motor_commands
    assert drives == tuple(
        MotorCommand(m.name, ControlMode.VELOCITY, 0.02) for m in ROBOT.drive_motors()
    )
    leds = raw("front_leds", ControlMode.PWM, 0.5)
    assert intent(leds).motor_commands == (leds.command,)
    tilt = raw("front_tilt", ControlMode.POSITION, 1.2)
    assert intent(tilt).motor_commands == (tilt.command,)


def test_a_stop_is_a_drive_at_zero_and_moves_nothing() -> None:
    for command in (Drive(0.0), raw("bend_2_drive", ControlMode.VELOCITY, 0.0)):
        it = intent(command)
        assert it.stop and it.drive_mps == 0.0 and not it.moves
        assert it.channels == BASE
    for command in (Drive(0.02), raw("bend_2_drive", ControlMode.VELOCITY, -0.02)):
        it = intent(command)
        assert not it.stop and it.moves and it.drive_mps == command_speed(command)
        assert it.channels == BASE


def command_speed(command: Command) -> float:
    return command.velocity_mps if isinstance(command, Drive) else command.command.value  # type: ignore[attr-defined]


def test_move_front_clear_goes_to_the_side_it_is_told() -> None:
    assert intent(MoveFrontClear()).front_tilt_rad == CLEAR
    assert intent(MoveFrontClear(0)).front_tilt_rad == CLEAR
    assert intent(MoveFrontClear(-1)).front_tilt_rad == -CLEAR
    assert intent(MoveFrontClear(-1)).motor_commands == (
        MotorCommand("front_tilt", ControlMode.POSITION, -CLEAR),
    )


def test_move_front_clear_ends_clear_even_where_the_loop_settles_short() -> None:
    # a position loop settles within the angle tolerance of its target: the target is
    # far enough past the clear angle that the low edge of that band is still clear
    target = intent(MoveFrontClear()).front_tilt_rad
    assert target is not None
    assert target - ROBOT.safety.angle_tolerance == pytest.approx(ROBOT.clamp.front_clear_angle)
    assert target < ROBOT.clamp.front_clear_angle + 2 * ROBOT.safety.angle_tolerance


def test_the_readings_each_decision_relies_on() -> None:
    tilt = "front_tilt_angle"
    assert intent(Clamp(Half.REAR, 0.5)).channels == BASE
    assert intent(Clamp(Half.FRONT, 0.5)).channels == (*BASE, tilt)
    assert intent(Rotate(0.1)).channels == (*BASE, "rotation_angle")
    assert intent(raw("rotate", ControlMode.POSITION, 0.1)).channels == (*BASE, "rotation_angle")
    assert intent(Tilt(0.5)).channels == (*BASE, tilt)
    assert intent(Unclamp(Half.FRONT)).channels == BASE  # straightening presses nothing
    assert intent(Unclamp(Half.FRONT, WALL)).channels == (*BASE, tilt)
    assert intent(Unclamp(Half.REAR, WALL)).channels == BASE
    assert intent(Bend("bend_1", WALL)).channels == (*BASE, tilt)
    assert intent(Bend("bend_3", WALL)).channels == BASE
    assert intent(raw("bend_1_joint", ControlMode.TORQUE, 0.1)).channels == (*BASE, tilt)
    assert intent(raw("bend_1_joint", ControlMode.TORQUE, 0.0)).channels == BASE
    assert intent(raw("bend_1_joint", ControlMode.TORQUE, 0.5)).channels == (*BASE, tilt)
    assert intent(raw("front_leds", ControlMode.PWM, 0.5)).channels == ()


def test_which_halves_a_command_clamps_releases_and_presses(port: FakePort) -> None:
    rear, front = frozenset({Half.REAR}), frozenset({Half.FRONT})
    clamp = intent(Clamp(Half.REAR, 0.5), port)
    assert (clamp.clamps, clamp.releases, clamp.presses) == (rear, frozenset(), frozenset())
    unclamp = intent(Unclamp(Half.FRONT), port)
    assert (unclamp.clamps, unclamp.releases, unclamp.presses) == (frozenset(), front, frozenset())
    at_wall = intent(Unclamp(Half.FRONT, -WALL), port)
    assert at_wall.presses == front and at_wall.releases == front
    bend = intent(Bend("bend_3", WALL - TOL), port)
    assert bend.presses == rear and bend.releases == rear
    short = intent(Bend("bend_3", WALL - TOL - 0.01), port)
    assert short.presses == frozenset() and short.releases == rear
    strong = intent(raw("bend_2_joint", ControlMode.TORQUE, ROBOT.clamp.min_torque), port)
    assert (strong.clamps, strong.releases, strong.presses) == (front, frozenset(), front)
    strong_back = intent(raw("bend_2_joint", ControlMode.TORQUE, -0.5), port)
    assert (strong_back.clamps, strong_back.presses) == (front, front)
    weak = intent(raw("bend_2_joint", ControlMode.TORQUE, ROBOT.clamp.min_torque / 2), port)
    assert (weak.clamps, weak.releases, weak.presses) == (frozenset(), front, front)
    zero = intent(raw("bend_2_joint", ControlMode.TORQUE, 0.0), port)
    assert (zero.clamps, zero.releases, zero.presses) == (frozenset(), front, frozenset())
    position = intent(raw("bend_2_joint", ControlMode.POSITION, WALL), port)
    assert (position.clamps, position.releases, position.presses) == (frozenset(), front, front)
    assert intent(raw("bend_2_joint", ControlMode.POSITION, 0.2), port).presses == frozenset()
    assert intent(Rotate(0.1), port).rotates
    assert intent(raw("rotate", ControlMode.POSITION, 0.1), port).rotates
    assert not intent(Tilt(0.5), port).rotates


def test_a_torque_across_a_joint_releases_its_half_on_the_way(port: FakePort) -> None:
    """A joint bent one way and pushed the other swings off the wall first."""
    rear = frozenset({Half.REAR})
    port.set(bend_3_angle=-1.0, bend_4_angle=-1.0)
    assert intent(Clamp(Half.REAR, 0.5), port).releases == rear
    assert intent(Clamp(Half.REAR, 0.5), port).clamps == rear
    assert intent(raw("bend_4_joint", ControlMode.TORQUE, 0.5), port).releases == rear
    assert intent(raw("bend_4_joint", ControlMode.TORQUE, -0.5), port).releases == frozenset()
    port.set(bend_3_angle=-TOL, bend_4_angle=TOL)  # straight within the tolerance
    assert intent(Clamp(Half.REAR, 0.5), port).releases == frozenset()
    assert intent(raw("bend_3_joint", ControlMode.TORQUE, -0.5), port).releases == frozenset()
    port.set(bend_3_angle=0.0, bend_4_angle=-TOL - 0.01)
    assert intent(Clamp(Half.REAR, 0.5), port).releases == rear
    # the other half's joints are not this half's business
    port.set(bend_3_angle=0.0, bend_4_angle=0.0, bend_1_angle=-1.0, bend_2_angle=-1.0)
    assert intent(Clamp(Half.REAR, 0.5), port).releases == frozenset()


def test_without_a_reading_a_clamp_is_taken_as_a_release() -> None:
    out = EXPANDER.expand(Clamp(Half.REAR, 0.5), None)
    assert isinstance(out, Intent) and out.releases == frozenset({Half.REAR})


# -- refusals at expansion ----------------------------------------------------------------


@pytest.mark.parametrize(
    "command",
    [
        Clamp(Half.REAR, math.nan),
        Unclamp(Half.REAR, math.inf),
        Bend("bend_1", -math.inf),
        Rotate(math.nan),
        Tilt(math.inf),
        Drive(math.nan),
        raw("bend_1_joint", ControlMode.TORQUE, math.nan),
    ],
    ids=str,
)
def test_a_value_that_is_not_a_number_is_refused_first(command: Command) -> None:
    found = problem(command)
    assert found.reason is Reason.NOT_FINITE
    assert found.detail == "command values must be finite numbers"


def test_a_clamp_exactly_at_the_holding_torque_is_a_clamp() -> None:
    held = ROBOT.clamp.min_torque
    assert intent(Clamp(Half.REAR, held)).clamps == frozenset({Half.REAR})
    found = problem(Clamp(Half.REAR, held * 0.99))
    assert found.reason is Reason.CLAMP_TORQUE_TOO_LOW
    assert found.detail == (
        f"clamp torque {held * 0.99:g} N·m is below the minimum that holds ({held:g} N·m)"
    )


def test_unknown_targets_and_modes_are_named() -> None:
    for module in ("front", "rotational", "nowhere"):
        found = problem(Bend(module, 0.1))
        assert (found.reason, found.detail) == (
            Reason.UNKNOWN_TARGET,
            f"{module!r} is not a bend module",
        )
    found = problem(raw("nope", ControlMode.PWM, 0.0))
    assert (found.reason, found.detail) == (Reason.UNKNOWN_TARGET, "unknown motor 'nope'")
    found = problem(raw("front_leds", ControlMode.TORQUE, 0.0))
    assert (found.reason, found.detail) == (
        Reason.MODE_NOT_ALLOWED,
        "motor 'front_leds' has no torque mode",
    )
    found = problem(raw("bend_1_joint", ControlMode.PWM, 0.1))
    assert (found.reason, found.detail) == (
        Reason.MODE_NOT_ALLOWED,
        "bend motor 'bend_1_joint' accepts only torque, position through the supervisor",
    )


def robot_variant(tmp_path: Path, *edits: tuple[str, str]) -> Path:
    text = (Path(__file__).parents[1] / "hardware" / "pirate.yaml").read_text()
    for old, new in edits:
        assert old in text, old
        text = text.replace(old, new)
    tmp_path.mkdir(parents=True, exist_ok=True)
    path = tmp_path / "variant.yaml"
    path.write_text(text)
    return path


def test_a_joint_motor_on_a_module_that_is_not_a_bend_module_is_no_bend_target(
    tmp_path: Path,
) -> None:
    """The front module's tilt motor declared as a bend joint: still not a bend module."""
    robot = load_robot(
        robot_variant(
            tmp_path,
            (
                "name: front_tilt\n        function: tilt",
                "name: front_tilt\n        function: bend",
            ),
        )
    )
    expander = Expander(robot)
    found = expander.expand(Bend("front", 0.1), FakePort(robot, SimClock()).state())
    assert isinstance(found, Problem)
    assert (found.reason, found.detail) == (Reason.UNKNOWN_TARGET, "'front' is not a bend module")
    tilt = expander.expand(Tilt(0.5), FakePort(robot, SimClock()).state())
    assert isinstance(tilt, Problem)
    assert (tilt.reason, tilt.detail) == (
        Reason.UNKNOWN_TARGET,
        "this robot has no front tilt motor",
    )


def test_a_tilt_motor_without_an_angle_sensor_cannot_be_commanded(tmp_path: Path) -> None:
    """No angle reading on the front module: nothing can check a tilt, so it is no target.
    (Its motors then have no position mode: a board closes a position loop on the angle
    sensor of the motor's slot, and a robot without one is refused at load.)"""
    robot = load_robot(
        robot_variant(
            tmp_path,
            (
                "    sensors:\n      - {<<: *angle_sensor, slot: 0, name: front_tilt_angle}\n",
                "    sensors: []\n",
            ),
            (
                "    sensors:\n      - {<<: *angle_sensor, slot: 0, name: camera_tilt_angle}\n"
                "      - {<<: *angle_sensor, slot: 1, name: camera_pan_angle}\n",
                "    sensors: []\n",
            ),
            (
                "          position: {raw: [-2048, 2047], per_raw: 0.087890625 deg}\n"
                "        limits:\n          angle: {min: -90 deg,",
                "        limits:\n          angle: {min: -90 deg,",
            ),
            (
                "        function: tilt\n        modes: *joint_modes\n",
                "        function: tilt\n        modes:\n"
                "          pwm: {raw: [-255, 255], per_raw: 0.392156862745098 %}\n"
                "          torque: {raw: [-1023, 1023], per_raw: 1 mN*m}\n",
            ),
        )
    )
    found = Expander(robot).expand(Tilt(0.5), FakePort(robot, SimClock()).state())
    assert isinstance(found, Problem)
    assert (found.reason, found.detail) == (
        Reason.UNKNOWN_TARGET,
        "this robot has no front tilt motor",
    )


# -- what the operator sees when an intent is right --------------------------------------------


def test_a_raw_drive_is_refused_while_a_half_is_in_transition(
    sup: Supervisor, port: FakePort
) -> None:
    port.clamp_half(Half.REAR)
    port.half_between(Half.FRONT)
    v = sup.command(raw("bend_1_drive", ControlMode.VELOCITY, 0.02))
    assert v.reason is Reason.HALF_TRANSITIONING
    assert sup.command(raw("bend_1_drive", ControlMode.VELOCITY, 0.0)).ok  # stopping is fine


def test_a_raw_drive_relies_on_fresh_readings(
    sup: Supervisor, port: FakePort, clock: SimClock
) -> None:
    port.clamp_half(Half.REAR)
    port.freeze("bend_4_spring")
    clock.advance(1.0)
    v = sup.command(raw("bend_1_drive", ControlMode.VELOCITY, 0.02))
    assert v.reason is Reason.STALE_STATE


def test_a_raw_rotation_needs_exactly_one_half_clamped(sup: Supervisor, port: FakePort) -> None:
    port.clamp_half(Half.REAR)
    port.clamp_half(Half.FRONT)
    v = sup.command(raw("rotate", ControlMode.POSITION, 0.05))
    assert v.reason is Reason.ROTATE_NEEDS_ONE_CLAMPED
    port.free_half(Half.FRONT)
    assert sup.command(raw("rotate", ControlMode.POSITION, 0.05)).outcome is Outcome.PASS


def test_a_stale_front_tilt_reading_blocks_a_front_clamp_only(
    sup: Supervisor, port: FakePort, clock: SimClock
) -> None:
    port.freeze("front_tilt_angle")
    clock.advance(1.0)
    assert sup.command(Clamp(Half.FRONT, 0.5)).reason is Reason.STALE_STATE
    assert sup.command(Clamp(Half.REAR, 0.5)).ok


def test_a_clamp_with_no_state_yet_is_refused_not_an_error(clock: SimClock) -> None:
    class Silent(FakePort):
        def state(self) -> None:  # type: ignore[override]
            return None

    sup = Supervisor(Silent(ROBOT, clock), clock)
    assert sup.command(Clamp(Half.REAR, 0.5)).reason is Reason.NO_STATE


def test_a_clamp_across_from_the_holding_side_needs_the_other_half(
    sup: Supervisor, port: FakePort
) -> None:
    """Rear joints holding on the other side: a clamp swings them off the wall first."""
    port.clamp_half(Half.REAR)
    wall = -port.values["bend_3_angle"]
    port.set(bend_3_angle=wall, bend_4_angle=wall)  # at the wall, pressing, bent the other way
    assert sup.half_states()[Half.REAR].value == "clamped"
    assert sup.check(Clamp(Half.REAR, 0.5)).reason is Reason.OTHER_HALF_NOT_CLAMPED
    # bent the other way but free (off the wall, no force): there is nothing to let go
    # of, so the clamp is no release (it is the clamp that stops a robot sliding in a
    # steep pipe with no half clamped)
    port.free_half(Half.REAR, angle_rad=-1.0)
    assert sup.half_states()[Half.REAR].value == "unclamped"
    assert sup.check(Clamp(Half.REAR, 0.5)).ok
    port.set(bend_3_angle=0.0, bend_4_angle=0.0)
    port.free_half(Half.FRONT, angle_rad=-0.2)  # the other half's joints do not matter
    assert sup.check(Clamp(Half.REAR, 0.5)).ok


def test_a_zero_torque_on_a_front_joint_presses_nothing(sup: Supervisor, port: FakePort) -> None:
    port.clamp_half(Half.REAR)
    port.set_tilt(0.0)  # the front module in the way
    assert sup.check(raw("bend_1_joint", ControlMode.TORQUE, 0.0)).ok
    assert sup.check(raw("bend_1_joint", ControlMode.TORQUE, 0.1)).reason is Reason.FRONT_NOT_CLEAR


def test_a_front_target_exactly_at_the_wall_presses_it(sup: Supervisor, port: FakePort) -> None:
    port.clamp_half(Half.REAR)
    port.set_tilt(0.0)
    port.set(bend_1_angle=WALL - TOL)  # no rate limit in the way
    assert sup.check(Bend("bend_1", WALL - TOL)).reason is Reason.FRONT_NOT_CLEAR
    assert sup.check(Bend("bend_1", WALL - TOL - 0.01)).ok


def test_a_bend_is_a_position_setpoint_within_the_joint_range(
    sup: Supervisor, port: FakePort
) -> None:
    port.clamp_half(Half.FRONT)
    hi = ROBOT.motor("bend_3_joint").limits.angle.max  # type: ignore[union-attr]
    port.set(bend_3_angle=hi)
    v = sup.command(Bend("bend_3", hi + 0.2))
    assert v.outcome is Outcome.CLIP and v.reason is Reason.ANGLE_LIMIT
    assert v.sent == (MotorCommand("bend_3_joint", ControlMode.POSITION, hi),)


def test_an_unclamp_moves_only_its_own_half(sup: Supervisor, port: FakePort) -> None:
    port.clamp_half(Half.FRONT)
    v = sup.command(Unclamp(Half.REAR))
    assert [c.motor for c in v.sent] == ["bend_3_joint", "bend_4_joint"]
    assert all(c.mode is ControlMode.POSITION for c in v.sent)


def test_a_raw_tilt_is_judged_like_a_tilt(sup: Supervisor, port: FakePort) -> None:
    """With the front half clamped the module may not leave its clear position, by hand too."""
    port.clamp_half(Half.REAR)
    port.clamp_half(Half.FRONT)
    assert sup.check(Tilt(0.0)).reason is Reason.FRONT_NOT_CLEAR
    v = sup.check(raw("front_tilt", ControlMode.POSITION, 0.0))
    assert v.reason is Reason.FRONT_NOT_CLEAR
    assert intent(raw("front_tilt", ControlMode.POSITION, 0.5)).front_tilt_rad == 0.5


def test_a_position_tilt_without_a_tilt_reading_is_refused_at_load(tmp_path: Path) -> None:
    """A front tilt with a position mode and no angle sensor on its slot: its board could
    not close the loop (the reference PICO brakes it), so the robot is refused at load
    (since 53fb687; before, the expander answered a raw tilt: no front tilt motor)."""
    path = robot_variant(
        tmp_path,
        (
            "    sensors:\n      - {<<: *angle_sensor, slot: 0, name: front_tilt_angle}\n",
            "    sensors: []\n",
        ),
        (
            "    sensors:\n      - {<<: *angle_sensor, slot: 0, name: camera_tilt_angle}\n"
            "      - {<<: *angle_sensor, slot: 1, name: camera_pan_angle}\n",
            "    sensors: []\n",
        ),
    )
    with pytest.raises(ValidationFailed, match=r"motor 'front_tilt' .* has a position mode"):
        load_robot(path)


def test_a_raw_tilt_commands_the_motor_it_names(tmp_path: Path) -> None:
    """A tilt motor on another module than the front: a raw command goes to that motor."""
    robot = load_robot(
        robot_variant(
            tmp_path,
            (
                "        name: rear_leds\n        function: leds\n        modes:\n"
                "          pwm: {raw: [0, 255], per_raw: 0.392156862745098 %}",
                "        name: rear_tilt\n        function: tilt\n        modes:\n"
                "          position: {raw: [-2048, 2047], per_raw: 0.087890625 deg}",
            ),
            (  # its board closes the position loop on the angle sensor of its slot
                "      - {<<: *angle_sensor, slot: 0, name: rear_angle}\n",
                "      - {<<: *angle_sensor, slot: 0, name: rear_angle}\n"
                "      - {<<: *angle_sensor, slot: 1, name: rear_tilt_angle}\n",
            ),
        )
    )
    mc = MotorCommand("rear_tilt", ControlMode.POSITION, 0.25)
    found = Expander(robot).expand(Raw(mc), FakePort(robot, SimClock()).state())
    assert isinstance(found, Intent)
    assert found.motor_commands == (mc,) and found.front_tilt_rad == 0.25


IMU = "        name: imu\n        kind: imu\n"


def test_the_readings_every_decision_relies_on_follow_the_robot(tmp_path: Path) -> None:
    """Joint angles, springs where there are springs, the IMU's pitch where it reads one."""
    angles = tuple(f"bend_{i}_angle" for i in (1, 2, 3, 4))
    springs = tuple(f"bend_{i}_spring" for i in (1, 2, 3, 4))
    assert set(BASE) == {*angles, *springs, "imu.pitch"}
    no_springs = load_robot(
        robot_variant(
            tmp_path / "a",
            *(
                (f"      - {{<<: *spring_sensor, slot: 1, name: bend_{i}_spring}}\n", "")
                for i in (1, 2, 3, 4)
            ),
        )
    )
    assert Expander(no_springs).base_channels == (*angles, "imu.pitch")
    no_pitch = load_robot(robot_variant(tmp_path / "b", (IMU, IMU + "        axes: [roll, yaw]\n")))
    assert "imu.pitch" not in Expander(no_pitch).base_channels
    no_imu = load_robot(
        robot_variant(
            tmp_path / "c",
            (
                "    sensors:\n      - slot: 0\n"
                + IMU
                + "        raw: [-31416, 31416]          # +-pi: the angles an IMU reads\n"
                "        per_raw: 0.1 mrad\n        period: 10 ms\n        assumption: true\n",
                "    sensors: []\n",
            ),
        )
    )
    assert no_imu.imu() is None
    assert "imu.pitch" not in Expander(no_imu).base_channels


def test_a_stop_is_not_expanded() -> None:
    """``Stop`` goes to the drives directly (it always passes); expanding it is an error."""
    from pirate_bt.safety import Stop

    found = EXPANDER.expand(Stop(), None)
    assert isinstance(found, Problem)
    assert (found.reason, found.detail) == (Reason.UNKNOWN_TARGET, "not a command: Stop()")
