"""The state invariants at their edges: clamp classification, freshness, a steep pipe, the
front module, and what each refusal says.

Written with the mutation run (docs/testing.md). Every threshold is tried exactly at its
value (where the robot description puts the edge, the edge belongs to the safe side), a
clamp state that cannot be read blocks a drive, and every refusal's sentence is checked
as an operator reads it.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from pirate_bt.clock import SimClock
from pirate_bt.robot import Half, load_robot
from pirate_bt.robot.description import RobotDescription
from pirate_bt.safety import (
    Clamp,
    ClampState,
    Drive,
    MoveFrontClear,
    Reason,
    Rotate,
    Supervisor,
    Tilt,
    Unclamp,
)
from pirate_bt.safety.checks import (
    CheckContext,
    HalfTarget,
    Intent,
    check_front_clear,
    check_other_half_clamped,
    check_steep_pipe,
    check_transitioning,
    classify_half,
    front_tilt_channel,
    half_states,
    is_steep,
    pressing_over_opening,
    stale_channels,
)
from pirate_bt.safety.expand import Expander
from pirate_bt.safety.testing import FakePort

ROBOT = load_robot()
TOL = ROBOT.safety.angle_tolerance
CONTACT_MIN = min(p.angle for p in ROBOT.clamp.contact_angles) - TOL
HOLD_N = ROBOT.clamp.holding_force_n
RELEASE_N = ROBOT.safety.release_force_fraction * HOLD_N
CLEAR = ROBOT.clamp.front_clear_angle - TOL
SLOPE = ROBOT.motion.max_unclamped_slope


@pytest.fixture
def clock() -> SimClock:
    return SimClock(0.0)


@pytest.fixture
def port(clock: SimClock) -> FakePort:
    return FakePort(ROBOT, clock)


@pytest.fixture
def sup(port: FakePort, clock: SimClock) -> Supervisor:
    return Supervisor(port, clock)


def rear(port: FakePort, angles: tuple[float, float], forces: tuple[float, float]) -> None:
    port.set(
        bend_3_angle=angles[0],
        bend_4_angle=angles[1],
        bend_3_spring=forces[0],
        bend_4_spring=forces[1],
    )


def rear_state(port: FakePort, robot: RobotDescription = ROBOT) -> ClampState:
    state = port.state()
    assert state is not None
    return classify_half(robot, state, Half.REAR)


def variant(tmp_path: Path, *edits: tuple[str, str]) -> RobotDescription:
    text = (Path(__file__).parents[1] / "hardware" / "pirate.yaml").read_text()
    for old, new in edits:
        assert old in text, old
        text = text.replace(old, new)
    path = tmp_path / "variant.yaml"
    path.write_text(text)
    return load_robot(path)


# -- clamp classification ------------------------------------------------------------------


@pytest.mark.parametrize("side", [1.0, -1.0])
def test_joints_exactly_at_the_smallest_contact_angle_are_at_the_wall(
    port: FakePort, side: float
) -> None:
    rear(port, (side * CONTACT_MIN, side * CONTACT_MIN), (HOLD_N, HOLD_N))
    assert rear_state(port) is ClampState.CLAMPED
    rear(port, (side * CONTACT_MIN, side * (CONTACT_MIN - 0.01)), (HOLD_N, HOLD_N))
    assert rear_state(port) is ClampState.TRANSITIONING


def test_joints_at_the_wall_on_opposite_sides_do_not_hold(port: FakePort) -> None:
    rear(port, (CONTACT_MIN, -CONTACT_MIN), (HOLD_N, HOLD_N))
    assert rear_state(port) is ClampState.TRANSITIONING
    rear(port, (1.5, -1.5), (HOLD_N, HOLD_N))
    assert rear_state(port) is ClampState.TRANSITIONING


def test_a_spring_reading_exactly_at_the_release_force_is_not_released(port: FakePort) -> None:
    rear(port, (0.2, 0.2), (RELEASE_N, 0.0))
    assert rear_state(port) is ClampState.TRANSITIONING
    rear(port, (0.2, 0.2), (RELEASE_N * 0.99, RELEASE_N * 0.5))
    assert rear_state(port) is ClampState.UNCLAMPED
    rear(port, (0.2, 0.2), (-RELEASE_N * 0.99, 0.0))  # the spring's sign does not matter
    assert rear_state(port) is ClampState.UNCLAMPED


def test_a_half_with_one_spring_silent_is_judged_by_its_joint_angles(port: FakePort) -> None:
    rear(port, (1.45, 1.45), (HOLD_N, 0.0))
    del port.values["bend_3_spring"]
    assert rear_state(port) is ClampState.CLAMPED
    rear(port, (0.1, 0.1), (0.0, HOLD_N))
    del port.values["bend_3_spring"]
    assert rear_state(port) is ClampState.UNCLAMPED


def test_a_half_with_a_joint_unread_is_unknown_and_blocks_a_drive(
    sup: Supervisor, port: FakePort
) -> None:
    port.clamp_half(Half.FRONT)
    del port.values["bend_4_angle"]
    assert rear_state(port) is ClampState.UNKNOWN
    assert sup.half_states()[Half.REAR] is ClampState.UNKNOWN
    v = sup.command(Drive(0.02))
    assert v.refused and v.reason is not None
    # the freshness check or the transition check refuses, never a pass
    fresh_port = FakePort(ROBOT, sup.clock)
    fresh_port.clamp_half(Half.FRONT)
    state = fresh_port.state()
    assert state is not None
    from pirate_bt.safety.checks import Intent, check_transitioning

    ctx = CheckContext(
        ROBOT, state, 0.0, {Half.FRONT: ClampState.CLAMPED, Half.REAR: ClampState.UNKNOWN}
    )
    found = check_transitioning(ctx, Intent(Drive(0.02), (), drive_mps=0.02))
    assert found is not None and found.reason is Reason.HALF_TRANSITIONING
    assert found.detail == "no drive while the rear half is unknown (between unclamped and clamped)"


def test_without_springs_the_joint_angles_decide(tmp_path: Path, clock: SimClock) -> None:
    robot = variant(
        tmp_path,
        *(
            (f"      - {{<<: *spring_sensor, slot: 1, name: bend_{i}_spring}}\n", "")
            for i in (1, 2, 3, 4)
        ),
    )
    port = FakePort(robot, clock)
    below = robot.clamp.unclamped_below
    rear(port, (below * 0.99, -below * 0.99), (0.0, 0.0))
    assert rear_state(port, robot) is ClampState.UNCLAMPED
    rear(port, (below, 0.0), (0.0, 0.0))
    assert rear_state(port, robot) is ClampState.TRANSITIONING
    rear(port, (CONTACT_MIN, CONTACT_MIN), (0.0, 0.0))
    assert rear_state(port, robot) is ClampState.CLAMPED


def test_a_release_in_progress_ends_when_the_sensors_say_free(
    sup: Supervisor, port: FakePort
) -> None:
    port.clamp_half(Half.FRONT)
    port.clamp_half(Half.REAR)
    assert sup.command(Unclamp(Half.REAR)).ok
    assert sup.half_states()[Half.REAR] is ClampState.TRANSITIONING  # still holds
    port.free_half(Half.REAR)
    assert sup.half_states()[Half.REAR] is ClampState.UNCLAMPED
    assert sup.command(Drive(0.02)).ok


# -- which sensor reads the front tilt -----------------------------------------------------


def test_the_front_tilt_is_read_by_the_angle_sensor_at_its_motor_s_slot(tmp_path: Path) -> None:
    assert front_tilt_channel(ROBOT) == "front_tilt_angle"
    spare = variant(
        tmp_path,
        (
            "    sensors:\n      - {<<: *angle_sensor, slot: 0, name: front_tilt_angle}\n",
            "    sensors:\n      - {<<: *angle_sensor, slot: 1, name: front_spare_angle}\n"
            "      - {<<: *angle_sensor, slot: 0, name: front_tilt_angle}\n",
        ),
    )
    assert front_tilt_channel(spare) == "front_tilt_angle"


def test_without_a_sensor_at_its_slot_the_front_module_s_angle_sensor_reads_it(
    tmp_path: Path,
) -> None:
    # a tilt motor with no position mode: one with a position mode needs an angle sensor
    # on its own slot (its board closes the loop on it), or the robot is refused at load
    robot = variant(
        tmp_path,
        (
            "    sensors:\n      - {<<: *angle_sensor, slot: 0, name: front_tilt_angle}\n",
            "    sensors: []\n",
        ),
        (
            "        function: tilt\n        modes: *joint_modes\n",
            "        function: tilt\n        modes:\n"
            "          pwm: {raw: [-255, 255], per_raw: 0.392156862745098 %}\n"
            "          torque: {raw: [-1023, 1023], per_raw: 1 mN*m}\n",
        ),
    )
    assert front_tilt_channel(robot) == "camera_tilt_angle"


# -- freshness and slope, at their edges ----------------------------------------------------


def test_a_reading_exactly_at_its_freshness_limit_is_fresh(port: FakePort, clock: SimClock) -> None:
    limit = ROBOT.safety.stale_after_periods * 0.01
    port.freeze("bend_1_angle")
    clock.advance(limit)
    state = port.state()
    assert state is not None
    assert stale_channels(ROBOT, state, ("bend_1_angle",), clock.now()) == []
    later = clock.now() + 0.001
    assert stale_channels(ROBOT, state, ("bend_1_angle",), later) == [
        ("bend_1_angle", pytest.approx(limit + 0.001))
    ]


def test_freshness_follows_each_sensor_s_own_period(tmp_path: Path, clock: SimClock) -> None:
    robot = variant(
        tmp_path,
        (
            "    per_raw: 50 mN\n    period: 10 ms",
            "    per_raw: 50 mN\n    period: 50 ms",
        ),
    )
    port = FakePort(robot, clock)
    port.freeze("bend_1_spring", "bend_1_angle")
    clock.advance(0.3)
    state = port.state()
    assert state is not None
    names = ("bend_1_spring", "bend_1_angle", "no_such_channel")
    stale = [name for name, _ in stale_channels(robot, state, names, clock.now())]
    assert stale == ["bend_1_angle", "no_such_channel"]  # unknown: never read


def test_a_pipe_exactly_at_the_unclamped_slope_is_not_steep(port: FakePort) -> None:
    for pitch, steep in (
        (SLOPE, False),
        (-SLOPE, False),
        (SLOPE * 1.01, True),
        (-SLOPE * 1.01, True),
    ):
        port.set_pitch(pitch)
        state = port.state()
        assert state is not None
        assert is_steep(ROBOT, state) is steep


# -- the steep pipe check's sentences --------------------------------------------------------


def test_steep_pipe_refusals_say_where_and_why(sup: Supervisor, port: FakePort) -> None:
    port.set_pitch(math.radians(20))
    no_clamp = sup.check(Drive(0.02))
    assert no_clamp.reason is Reason.STEEP_PIPE_UNCLAMPED
    assert (
        no_clamp.detail == "no half is clamped in a steep pipe (pitch 20.0° > 10.0°): clamp first"
    )
    port.clamp_half(Half.REAR)
    release = sup.check(Unclamp(Half.REAR))
    assert release.reason is Reason.STEEP_PIPE_UNCLAMPED
    assert release.detail == (
        "releasing the rear half would leave no half clamped in a steep pipe (pitch 20.0° > 10.0°)"
    )
    del port.values["imu.pitch"]  # no reading counts as steep
    state = port.state()
    assert state is not None
    intent = Expander(ROBOT).expand(Unclamp(Half.REAR), state)
    ctx = CheckContext(ROBOT, state, 0.0, sup.half_states())
    found = check_steep_pipe(ctx, intent)  # type: ignore[arg-type]
    assert found is not None and found.detail == (
        "releasing the rear half would leave no half clamped in a steep pipe"
        " (no pitch reading > 10.0°)"
    )


def test_a_stop_and_a_zero_drive_pass_in_a_steep_pipe_with_nothing_clamped(
    sup: Supervisor, port: FakePort
) -> None:
    port.set_pitch(math.radians(80))
    assert sup.command(Drive(0.0)).ok


# -- the other invariants' sentences -----------------------------------------------------------


def test_other_half_refusals_name_both_halves(sup: Supervisor, port: FakePort) -> None:
    port.half_between(Half.FRONT)
    v = sup.check(Unclamp(Half.REAR))
    assert v.reason is Reason.OTHER_HALF_NOT_CLAMPED
    assert v.detail == (
        "the rear half may unclamp or bend only while the front half is clamped"
        " (it is transitioning)"
    )


def test_a_check_with_no_clamp_states_takes_them_as_unknown(port: FakePort) -> None:
    state = port.state()
    assert state is not None
    ctx = CheckContext(ROBOT, state, 0.0)
    intent = Expander(ROBOT).expand(Unclamp(Half.REAR), state)
    found = check_other_half_clamped(ctx, intent)  # type: ignore[arg-type]
    assert found is not None and found.detail.endswith("(it is unknown)")
    tilt = Expander(ROBOT).expand(Tilt(0.0), state)
    found = check_front_clear(ctx, tilt)  # type: ignore[arg-type]
    assert found is not None and found.detail == (
        "the front module may leave its clear position only while the front half is"
        " unclamped (it is unknown)"
    )


def test_rotation_refusals_count_and_name_the_halves(sup: Supervisor, port: FakePort) -> None:
    v = sup.check(Rotate(0.05))
    assert v.reason is Reason.ROTATE_NEEDS_ONE_CLAMPED
    assert v.detail == (
        "rotation needs exactly one half clamped (0 are: front unclamped, rear unclamped)"
    )
    port.clamp_half(Half.REAR)
    port.half_between(Half.FRONT)
    v = sup.check(Rotate(0.05))
    assert v.reason is Reason.HALF_TRANSITIONING
    assert v.detail == "rotation needs the front half free, but it is transitioning"
    port.clamp_half(Half.FRONT)
    v = sup.check(Rotate(0.05))
    assert (
        v.detail == "rotation needs exactly one half clamped (2 are: front clamped, rear clamped)"
    )


def test_any_speed_is_refused_while_a_half_is_in_transition(
    sup: Supervisor, port: FakePort
) -> None:
    port.clamp_half(Half.REAR)
    port.half_between(Half.FRONT)
    for speed in (0.02, 1.0, -1.0):
        v = sup.check(Drive(speed))
        assert v.reason is Reason.HALF_TRANSITIONING
        assert v.detail == (
            "no drive while the front half is transitioning (between unclamped and clamped)"
        )


# -- the front module -----------------------------------------------------------------------


def test_the_front_module_exactly_at_its_clear_angle_is_clear(
    sup: Supervisor, port: FakePort
) -> None:
    port.set_tilt(CLEAR)
    assert sup.check(Clamp(Half.FRONT, 0.5)).ok
    port.set_tilt(-CLEAR)
    assert sup.check(Clamp(Half.FRONT, 0.5)).ok
    port.set_tilt(CLEAR - 0.01)
    v = sup.check(Clamp(Half.FRONT, 0.5))
    assert v.reason is Reason.FRONT_NOT_CLEAR
    assert v.detail == (
        f"move the front module clear (|tilt| >= 60.0°, it is {math.degrees(CLEAR - 0.01):.1f}°)"
        " before the front half clamps or presses the wall"
    )


def test_an_unread_front_tilt_is_not_clear(sup: Supervisor, port: FakePort) -> None:
    del port.values["front_tilt_angle"]
    state = port.state()
    assert state is not None
    intent = Expander(ROBOT).expand(Clamp(Half.FRONT, 0.5), state)
    ctx = CheckContext(ROBOT, state, 0.0, sup.half_states())
    found = check_front_clear(ctx, intent)  # type: ignore[arg-type]
    assert found is not None and found.reason is Reason.FRONT_NOT_CLEAR
    assert found.detail == (
        "move the front module clear (|tilt| >= 60.0°, it is unknown)"
        " before the front half clamps or presses the wall"
    )


def test_a_clamped_front_half_keeps_the_module_exactly_clear(
    sup: Supervisor, port: FakePort
) -> None:
    """Moving from one clear position to another on the same side is allowed, edges included."""
    port.clamp_half(Half.REAR)
    port.set_tilt(CLEAR)
    port.clamp_half(Half.FRONT)
    assert sup.check(Tilt(CLEAR)).ok
    assert sup.check(MoveFrontClear()).ok
    assert sup.check(Tilt(CLEAR - 0.01)).reason is Reason.FRONT_NOT_CLEAR
    port.set_tilt(CLEAR - 0.01)
    v = sup.check(Tilt(CLEAR + 0.05))
    assert v.reason is Reason.FRONT_NOT_CLEAR
    assert v.detail == (
        "the front module may leave its clear position only while the front half is"
        " unclamped (it is clamped)"
    )


def test_a_release_of_both_halves_names_both(port: FakePort) -> None:
    port.set_pitch(math.radians(30))
    port.clamp_half(Half.FRONT)
    port.clamp_half(Half.REAR)
    state = port.state()
    assert state is not None
    both = frozenset(Half)
    from pirate_bt.safety.checks import Intent

    ctx = CheckContext(
        ROBOT, state, 0.0, {Half.FRONT: ClampState.CLAMPED, Half.REAR: ClampState.CLAMPED}
    )
    found = check_steep_pipe(ctx, Intent(Unclamp(Half.REAR), (), releases=both))
    assert found is not None and found.detail == (
        "releasing the front/rear half would leave no half clamped in a steep pipe"
        " (pitch 30.0° > 10.0°)"
    )


# -- a half crossing a tee's opening ----------------------------------------------------------

WALL = ROBOT.clamp.contact_angle(0.063)


def crossing(port: FakePort, swung: float = WALL + 0.4, force: float = 0.0) -> None:
    """Front clamped; the rear's bend_3 swung past the wall over an opening, bend_4 holding."""
    port.clamp_half(Half.FRONT)
    rear(port, (swung, WALL), (force, HOLD_N * 1.5))


def crossing_ctx(port: FakePort, **targets: HalfTarget) -> CheckContext:
    state = port.state()
    assert state is not None
    return CheckContext(
        ROBOT,
        state,
        0.0,
        half_states(ROBOT, state, {}),
        {Half(k): v for k, v in targets.items()},
    )


DRIVE = Intent(Drive(0.08), (), drive_mps=0.08)


def test_a_half_pressing_across_an_opening_may_drive_while_the_other_holds(
    sup: Supervisor, port: FakePort
) -> None:
    crossing(port)
    assert rear_state(port) is ClampState.TRANSITIONING
    state = port.state()
    assert state is not None and pressing_over_opening(ROBOT, state, Half.REAR)
    assert check_transitioning(crossing_ctx(port, rear=HalfTarget.CLAMP), DRIVE) is None
    # through the supervisor: it asked the rear half to clamp, so the drive goes out
    port.clamp_half(Half.REAR)
    assert not sup.command(Clamp(Half.REAR, 0.7)).refused
    crossing(port)
    v = sup.command(Drive(0.04))
    assert not v.refused, v.detail


@pytest.mark.parametrize(
    ("setup", "words"),
    [
        ("front between", "front half is transitioning"),  # the other half does not hold
        ("no target", "rear half is transitioning"),  # never asked to clamp
        ("releasing", "rear half is transitioning"),  # asked to let go
        ("swung joint still holds", "rear half is transitioning"),
        ("free joint short of the wall", "rear half is transitioning"),
        ("joints bend opposite ways", "rear half is transitioning"),
        ("a joint short of the wall", "rear half is transitioning"),
    ],
)
def test_anything_else_transitioning_is_still_refused(
    port: FakePort, setup: str, words: str
) -> None:
    crossing(port)
    target = HalfTarget.CLAMP
    if setup == "front between":
        port.half_between(Half.FRONT)
    elif setup == "no target":
        target = None  # type: ignore[assignment]
    elif setup == "releasing":
        target = HalfTarget.RELEASE
    elif setup == "swung joint still holds":
        crossing(port, force=HOLD_N * 1.5)
        port.set(bend_4_spring=HOLD_N * 0.5)  # the other joint then does not hold
    elif setup == "free joint short of the wall":
        crossing(port, swung=WALL - TOL - 0.005)  # letting go, not over an opening
    elif setup == "joints bend opposite ways":
        crossing(port, swung=-(WALL + 0.4))
    elif setup == "a joint short of the wall":
        rear(port, (WALL + 0.4, CONTACT_MIN - 0.01), (0.0, HOLD_N * 1.5))
    ctx = crossing_ctx(port, **({"rear": target} if target is not None else {}))
    found = check_transitioning(ctx, DRIVE)
    assert found is not None and found.reason is Reason.HALF_TRANSITIONING
    assert words in found.detail


def test_the_opening_exception_needs_the_springs(port: FakePort) -> None:
    crossing(port)
    del port.values["bend_3_spring"]
    state = port.state()
    assert state is not None and not pressing_over_opening(ROBOT, state, Half.REAR)
    crossing(port, swung=WALL - TOL)  # just starting to swing out, exactly: on nothing
    state = port.state()
    assert state is not None and pressing_over_opening(ROBOT, state, Half.REAR)
    crossing(port, swung=WALL + 0.01, force=ROBOT.clamp.holding_force_n)  # holds: clamped
    state = port.state()
    assert state is not None and not pressing_over_opening(ROBOT, state, Half.REAR)
    port.clamp_half(Half.REAR)  # every joint holding: clamped, no opening
    state = port.state()
    assert state is not None and not pressing_over_opening(ROBOT, state, Half.REAR)


def test_a_crossing_holds_from_the_smallest_contact_angle_and_either_way(port: FakePort) -> None:
    # a holding joint exactly at the smallest wall-contact angle (less the tolerance)
    port.clamp_half(Half.FRONT)
    rear(port, (CONTACT_MIN + 0.5, CONTACT_MIN), (0.0, HOLD_N))
    state = port.state()
    assert state is not None and pressing_over_opening(ROBOT, state, Half.REAR)
    rear(port, (CONTACT_MIN + 0.5, CONTACT_MIN - 0.001), (0.0, HOLD_N))  # short of it
    state = port.state()
    assert state is not None and not pressing_over_opening(ROBOT, state, Half.REAR)
    # bent the other way (negative angles), the same crossing
    rear(port, (-(WALL + 0.4), -WALL), (0.0, HOLD_N * 1.5))
    state = port.state()
    assert state is not None and pressing_over_opening(ROBOT, state, Half.REAR)
    rear(port, (-(WALL + 0.4), -(CONTACT_MIN - 0.01)), (0.0, HOLD_N * 1.5))
    state = port.state()
    assert state is not None and not pressing_over_opening(ROBOT, state, Half.REAR)
    # the holding joint on the other side from the free one
    rear(port, (-(WALL + 0.4), WALL), (0.0, HOLD_N * 1.5))
    state = port.state()
    assert state is not None and not pressing_over_opening(ROBOT, state, Half.REAR)
    rear(port, (WALL + 0.4, -WALL), (0.0, HOLD_N * 1.5))
    state = port.state()
    assert state is not None and not pressing_over_opening(ROBOT, state, Half.REAR)


def test_a_clamp_of_an_unclamped_half_is_no_release_even_across(port: FakePort) -> None:
    # both halves free in a steep pipe (a fault: the robot is sliding); the rear joints
    # steered the other way: its clamp swings them across, which counted as a release,
    # so the clamp that would stop the fall was refused
    port.set_pitch(math.radians(-90))
    state = port.state()
    assert state is not None
    from pirate_bt.safety.checks import Intent, check_other_half_clamped, loosened

    free = {Half.FRONT: ClampState.UNCLAMPED, Half.REAR: ClampState.UNCLAMPED}
    ctx = CheckContext(ROBOT, state, 0.0, free)
    clamp = Intent(
        Clamp(Half.REAR, 0.7), (), clamps=frozenset({Half.REAR}), releases=frozenset({Half.REAR})
    )
    assert loosened(ctx, clamp) == frozenset()
    assert check_steep_pipe(ctx, clamp) is None
    assert check_other_half_clamped(ctx, clamp) is None
    # a bend of a free half is still a release: it needs the other half clamped
    bend = Intent(Unclamp(Half.REAR), (), releases=frozenset({Half.REAR}))
    assert check_other_half_clamped(ctx, bend) is not None
    # and a half that holds still lets go when its clamp swings across
    held = CheckContext(ROBOT, state, 0.0, {**free, Half.REAR: ClampState.CLAMPED})
    assert loosened(held, clamp) == frozenset({Half.REAR})
    assert check_steep_pipe(held, clamp) is not None
