"""The simulator's physical rules (DOMAIN.md): each one triggers, and each one does not.

These drive :class:`PipeRobotModel` directly with SI motor commands, no wire and
no tree, in 10 ms steps.
"""

from __future__ import annotations

import math
import random

import pytest

from pirate_bt.pipes import load_network, network_from_data
from pirate_bt.robot import load_robot
from pirate_bt.robot.commands import MotorCommand
from pirate_bt.robot.description import ControlMode, Half, RobotDescription
from pirate_bt.sim import EventKind, PipeRobotModel, SensorNoise

ROBOT = load_robot()
DT = 0.01
CLAMP_NM = 0.7
STEER_RAD = math.radians(35)
SPEED = 0.08


class Driver:
    """Plain-Python motion primitives against the model (what a PAB does, without a tree)."""

    def __init__(self, network: str = "straight", robot: RobotDescription = ROBOT, **kw: object):
        net = load_network(network) if isinstance(network, str) else network
        self.robot = robot
        self.model = PipeRobotModel(robot, net, **kw)  # type: ignore[arg-type]
        self.front = [b.name for b in robot.bend_modules(Half.FRONT)]
        self.rear = [b.name for b in robot.bend_modules(Half.REAR)]

    def cmd(self, motor: str, mode: ControlMode, value: float) -> None:
        self.model.command(MotorCommand(motor, mode, value))

    def run(self, seconds: float) -> None:
        for _ in range(round(seconds / DT)):
            self.model.step(DT)

    def joints(self, half: Half, mode: ControlMode, value: float) -> None:
        for module in self.front if half is Half.FRONT else self.rear:
            self.cmd(self.robot.joint_motor(module).name, mode, value)

    def clamp(self, half: Half, torque_nm: float = CLAMP_NM) -> None:
        if half is Half.FRONT:
            self.cmd("front_tilt", ControlMode.POSITION, math.radians(70))
            self.run(1.0)
        self.joints(half, ControlMode.TORQUE, torque_nm)
        self.run(1.5)

    def release(self, half: Half, angle_rad: float = 0.0) -> None:
        self.joints(half, ControlMode.POSITION, angle_rad)
        self.run(1.5)

    def drive(self, velocity_mps: float, seconds: float) -> None:
        for motor in self.robot.drive_motors():
            self.cmd(motor.name, ControlMode.VELOCITY, velocity_mps)
        self.run(seconds)
        for motor in self.robot.drive_motors():
            self.cmd(motor.name, ControlMode.VELOCITY, 0.0)
        self.run(0.5)

    def drive_to(self, front_m: float) -> None:
        distance = front_m - self.model.truth().front_m
        self.drive(math.copysign(SPEED, distance), abs(distance) / SPEED + 0.25)

    def rotate(self, angle_rad: float) -> None:
        self.cmd("rotate", ControlMode.POSITION, angle_rad)
        self.run(4.0)

    def through_bend(self, roll_rad: float, *, rotation_rad: float | None = None) -> None:
        """Rear clamped: align and steer the front, drive it through; then the rear."""
        model = self.model
        turn = model.path.next_turn(model.truth().front_m)
        assert turn is not None
        self.clamp(Half.REAR)
        self.release(Half.FRONT)
        rot = roll_rad if rotation_rad is None else rotation_rad
        self.rotate(rot)
        self.joints(Half.FRONT, ControlMode.POSITION, STEER_RAD)
        self.run(1.0)
        self.drive_to(turn.end_m + 0.05)
        self.clamp(Half.FRONT)
        self.release(Half.REAR)
        self.rotate(0.0)
        self.joints(Half.REAR, ControlMode.POSITION, STEER_RAD)
        self.run(1.0)
        self.drive_to(turn.end_m + model.length_m + 0.05)
        self.clamp(Half.REAR)
        self.release(Half.FRONT)


def test_clamp_needs_contact_and_minimum_torque() -> None:
    d = Driver()
    d.clamp(Half.REAR, torque_nm=0.2)  # below clamp.min_torque
    rear = d.model.truth().halves[Half.REAR]
    assert not rear.clamped
    d.clamp(Half.REAR, torque_nm=0.5)
    truth = d.model.truth()
    assert truth.halves[Half.REAR].clamped
    contact = ROBOT.clamp.contact_angle(0.063)
    for module in d.rear:
        assert truth.joint_angle_rad[ROBOT.joint_motor(module).name] == pytest.approx(contact)
    # normal force = torque / lever arm, per joint; the spring sensors read it
    assert truth.halves[Half.REAR].normal_force_n == pytest.approx(2 * 0.5 / 0.04)
    assert d.model.readings()["bend_3_spring"] == pytest.approx(0.5 / 0.04)
    assert d.model.readings()["bend_1_spring"] == 0.0


def test_position_mode_short_of_the_wall_does_not_clamp() -> None:
    d = Driver()
    d.joints(Half.REAR, ControlMode.POSITION, 1.0)
    d.run(2.0)
    assert not d.model.truth().halves[Half.REAR].clamped
    assert d.model.truth().joint_angle_rad["bend_3_joint"] == pytest.approx(1.0)


def test_traction_moves_the_robot_when_clamped() -> None:
    d = Driver()
    d.clamp(Half.REAR)
    start = d.model.truth().front_m
    d.drive(SPEED, 5.0)
    assert d.model.truth().front_m - start == pytest.approx(0.4, abs=0.03)
    assert d.model.counters().slip_events == 0


def test_wheels_slip_when_unclamped_or_traction_too_low() -> None:
    d = Driver()
    start = d.model.truth().front_m
    d.drive(SPEED, 2.0)  # nothing clamped: no traction
    assert d.model.truth().front_m == pytest.approx(start)
    assert d.model.counters().slip_events == 1
    # clamped, but the tether drag beats the traction
    heavy = network_from_data(
        {
            "name": "drag",
            "diameter": "63 mm",
            "tether_drag_per_metre": "40 N",
            "segments": [{"type": "straight", "length": "5 m"}],
            "start": {"position": "1.5 m"},
        }
    )
    d = Driver(heavy)  # type: ignore[arg-type]
    d.clamp(Half.REAR)
    d.drive(SPEED, 2.0)
    assert d.model.truth().front_m == pytest.approx(1.5)
    assert d.model.counters().slip_events == 1
    assert d.model.readings()["bend_3_drive.current"] == pytest.approx(0.0)


def slope_network(slope: str) -> object:
    return network_from_data(
        {
            "name": "slope",
            "diameter": "63 mm",
            "slope": slope,
            "segments": [{"type": "straight", "length": "5 m"}],
            "start": {"position": "2 m"},
        }
    )


def test_unclamped_robot_slides_in_a_steep_pipe() -> None:
    d = Driver(slope_network("30 deg"))  # type: ignore[arg-type]
    put_in_m = d.model.truth().front_m
    d.run(1.0)  # held as it was put in, as an operator holds it until it clamps
    assert d.model.counters().violation_count == 0
    assert d.model.truth().front_m == pytest.approx(put_in_m)
    d.clamp(Half.REAR)
    d.run(0.5)
    d.release(Half.REAR)  # from its first clamp on, a free robot falls
    d.run(1.0)
    counters = d.model.counters()
    assert counters.violations == {"sliding": 1}
    assert counters.slide_m > 0.1
    assert d.model.truth().front_m < put_in_m - 0.1


def test_no_sliding_in_gentle_pipe_or_when_clamped() -> None:
    d = Driver(slope_network("5 deg"))  # type: ignore[arg-type]
    d.run(1.0)
    assert d.model.counters().violation_count == 0
    ramp = network_from_data(
        {
            "name": "ramp",
            "diameter": "63 mm",
            "segments": [
                {"type": "straight", "length": "1.5 m"},
                {"type": "straight", "length": "3 m", "slope": "30 deg"},
            ],
            "start": {"position": "1 m"},
        }
    )
    d = Driver(ramp)  # type: ignore[arg-type]
    d.clamp(Half.REAR)
    d.drive_to(2.5)
    d.run(2.0)
    assert math.degrees(d.model.truth().slope_rad) == pytest.approx(30.0)
    assert d.model.truth().front_m == pytest.approx(2.5, abs=0.05)
    assert d.model.counters().violation_count == 0
    d.release(Half.REAR)  # now it falls
    assert d.model.counters().violations == {"sliding": 1}


def test_gravity_is_a_load_uphill() -> None:
    d = Driver(slope_network("45 deg"))  # type: ignore[arg-type]
    d.clamp(Half.REAR, torque_nm=0.35)  # traction 0.6 * 17.5 N = 10.5 N < 15 N * sin 45°
    start = d.model.truth().front_m
    d.drive(SPEED, 2.0)
    assert d.model.truth().front_m == pytest.approx(start)
    assert d.model.counters().slip_events == 1


def test_scripted_manoeuvre_passes_a_bend() -> None:
    d = Driver("bend-right")
    d.through_bend(math.pi / 2)
    truth = d.model.truth()
    counters = d.model.counters()
    assert counters.stuck_events == 0
    assert counters.violation_count == 0
    assert counters.damage_count == 0
    assert truth.module_segment["rear"] == "after"
    assert truth.module_segment["front"] == "after"


@pytest.mark.parametrize(
    ("network", "rotation_deg"),
    [("bend-up", 0.0), ("bend-down", 180.0), ("bend-left", -90.0), ("bend-right", 90.0)],
)
def test_each_bend_orientation_has_its_rotation(network: str, rotation_deg: float) -> None:
    d = Driver(network)
    d.through_bend(math.radians(rotation_deg))
    assert d.model.counters().stuck_events == 0
    assert d.model.truth().module_segment["rear"] == "after"


def test_bend_down_also_passes_with_negative_steer() -> None:
    d = Driver("bend-down")
    global STEER_RAD
    saved = STEER_RAD
    STEER_RAD = -saved
    try:
        d.through_bend(0.0)
    finally:
        STEER_RAD = saved
    assert d.model.counters().stuck_events == 0
    assert d.model.truth().module_segment["rear"] == "after"


def test_wrong_roll_gets_stuck_and_counters_say_so() -> None:
    d = Driver("bend-right")
    d.clamp(Half.REAR)
    d.release(Half.FRONT)
    d.joints(Half.FRONT, ControlMode.POSITION, STEER_RAD)  # steered, but not rotated
    d.run(1.0)
    for motor in ROBOT.drive_motors():
        d.cmd(motor.name, ControlMode.VELOCITY, SPEED)
    d.run(25.0)
    model = d.model
    truth = model.truth()
    bend = model.path.next_turn(0.0)
    assert bend is not None
    assert truth.front_m == pytest.approx(bend.start_m)
    assert model.counters().stuck_events == 1
    assert truth.halves[Half.FRONT].stuck
    assert not truth.halves[Half.REAR].stuck
    assert [e.detail for e in model.events if e.kind is EventKind.STUCK] == ["front:bend"]


def test_stuck_when_unsteered_and_current_rises() -> None:
    d = Driver("bend-up")
    d.clamp(Half.REAR)
    for motor in ROBOT.drive_motors():
        d.cmd(motor.name, ControlMode.VELOCITY, SPEED)
    d.run(25.0)
    readings = d.model.readings()
    assert d.model.counters().stuck_events == 1
    assert readings["bend_3_drive.current"] == pytest.approx(ROBOT.motion.drive_stall_current)
    assert readings["bend_3_drive.velocity"] == 0.0  # blocked wheels


def test_moving_current_is_below_stall() -> None:
    d = Driver()
    d.clamp(Half.REAR)
    for motor in ROBOT.drive_motors():
        d.cmd(motor.name, ControlMode.VELOCITY, SPEED)
    d.run(2.0)
    current = d.model.readings()["bend_3_drive.current"]
    assert ROBOT.motion.drive_free_current <= current < ROBOT.motion.drive_stall_current


def test_rotate_with_one_half_clamped_turns_the_other() -> None:
    d = Driver()
    d.clamp(Half.REAR)
    d.rotate(math.radians(60))
    truth = d.model.truth()
    assert truth.halves[Half.FRONT].roll_rad == pytest.approx(math.radians(60))
    assert truth.halves[Half.REAR].roll_rad == pytest.approx(0.0)
    assert d.model.counters().violation_count == 0
    assert d.model.counters().damage_count == 0


def test_rotate_with_both_clamped_stalls_and_over_torques() -> None:
    d = Driver()
    d.clamp(Half.REAR)
    d.clamp(Half.FRONT)
    d.rotate(math.radians(60))
    truth = d.model.truth()
    assert truth.rotation_rad == pytest.approx(0.0)
    assert d.model.counters().damage == {"over_torque:rotate": 1}


def test_rotate_with_none_clamped_is_a_violation() -> None:
    d = Driver()
    d.rotate(math.radians(60))
    assert d.model.counters().violations == {"uncontrolled_rotation": 1}


def test_over_torque_needs_time_above_the_limit() -> None:
    d = Driver()
    d.cmd("bend_3_joint", ControlMode.TORQUE, 0.9)  # limit 0.8 N*m
    d.run(0.2)  # shorter than over_torque_time
    d.cmd("bend_3_joint", ControlMode.TORQUE, 0.5)
    d.run(1.0)
    assert d.model.counters().damage_count == 0
    d.cmd("bend_3_joint", ControlMode.TORQUE, 0.9)
    d.run(1.0)
    assert d.model.counters().damage == {"over_torque:bend_3_joint": 1}


def test_a_stalled_joint_in_torque_mode_applies_the_commanded_torque() -> None:
    """The board closes the torque loop: a joint blocked at the wall is no over-torque."""
    d = Driver()
    d.clamp(Half.FRONT)  # CLAMP_NM = 0.7 N*m, within the 0.8 N*m limit
    d.model.set_stalled("bend_1_joint", True)  # stalled against the wall
    d.run(2.0)
    assert d.model.counters().damage_count == 0
    assert d.model.truth().torque_nm["bend_1_joint"] == pytest.approx(CLAMP_NM)
    # a commanded torque over the limit is damage, stalled or not
    d.cmd("bend_1_joint", ControlMode.TORQUE, 0.9)
    d.run(1.0)
    assert d.model.counters().damage == {"over_torque:bend_1_joint": 1}


def test_a_stalled_joint_in_pwm_mode_applies_its_share_of_the_stall_torque() -> None:
    d = Driver()
    d.model.set_stalled("bend_3_joint", True)
    d.cmd("bend_3_joint", ControlMode.PWM, 0.5)  # 0.5 x 1.023 N*m, within the limit
    d.run(1.0)
    assert d.model.counters().damage_count == 0
    d.cmd("bend_3_joint", ControlMode.PWM, 1.0)  # full duty into a blocked motor
    d.run(1.0)
    assert d.model.counters().damage == {"over_torque:bend_3_joint": 1}


def test_front_clamp_needs_the_front_module_clear() -> None:
    d = Driver()
    d.joints(Half.FRONT, ControlMode.TORQUE, CLAMP_NM)  # front tilt still at 0
    d.run(1.5)
    assert d.model.counters().damage == {"front_pressed": 1}
    d = Driver()
    d.clamp(Half.FRONT)  # tilts the front module clear first
    assert d.model.counters().damage_count == 0
    assert d.model.truth().halves[Half.FRONT].clamped


def test_tee_straight_needs_the_other_half_to_hold() -> None:
    d = Driver("t-joint")
    tee = next(p for p in d.model.path.pieces if p.segment == "tee")
    assert tee.opening_m is not None
    d.clamp(Half.REAR)
    d.drive_to(tee.opening_m + 0.1)  # front bend modules over the opening
    d.clamp(Half.FRONT)
    assert not d.model.truth().halves[Half.FRONT].clamped
    assert d.model.truth().path_choices == {"tee": "straight"}
    d.release(Half.FRONT)
    d.drive_to(tee.opening_m + 0.25)  # front half past the opening, rear not yet on it
    d.clamp(Half.FRONT)
    assert d.model.truth().halves[Half.FRONT].clamped
    d.release(Half.REAR)
    d.drive_to(tee.opening_m + 0.5)
    d.clamp(Half.REAR)
    truth = d.model.truth()
    assert truth.halves[Half.REAR].clamped
    assert truth.halves[Half.REAR].segments == ("after", "after")
    assert d.model.counters().stuck_events == 0


def test_tee_straight_with_both_halves_over_the_opening_slips() -> None:
    d = Driver("t-joint")
    tee = next(p for p in d.model.path.pieces if p.segment == "tee")
    assert tee.opening_m is not None
    d.clamp(Half.REAR)
    d.drive_to(tee.opening_m + 0.6)  # the rear half reaches the opening and loses its grip
    assert d.model.truth().front_m < tee.opening_m + 0.35
    assert d.model.counters().slip_events == 1


def test_tee_branch_is_taken_when_steered_toward_it() -> None:
    d = Driver("t-joint")
    d.clamp(Half.REAR)
    d.release(Half.FRONT)
    d.rotate(-math.pi / 2)
    d.joints(Half.FRONT, ControlMode.POSITION, STEER_RAD)
    d.run(1.0)
    d.drive_to(2.3)
    truth = d.model.truth()
    assert truth.path_choices == {"tee": "branch"}
    assert truth.module_segment["front"] == "branch"


def test_same_seed_same_noise() -> None:
    a = Driver(seed=3, noise=SensorNoise.typical())
    b = Driver(seed=3, noise=SensorNoise.typical())
    c = Driver(seed=4, noise=SensorNoise.typical())
    for d in (a, b, c):
        d.clamp(Half.REAR)
    assert a.model.readings() == b.model.readings()
    assert a.model.readings() != c.model.readings()


def test_noise_is_random_gauss_per_noisy_channel_in_frame_order() -> None:
    # The noise of a seed is what it always was (recorded runs and campaigns stay
    # comparable): random.Random(seed).gauss(0, sigma) for each noisy channel in turn,
    # frame after frame, drawn in one loop per frame rather than a call per channel.
    noise = SensorNoise.typical()
    noisy = Driver(seed=5, noise=noise)
    clean = Driver(seed=5)
    reference = random.Random(5)
    sigma = {"angle": noise.angle_rad, "imu": noise.angle_rad, "spring": noise.force_n}
    sigma |= {"velocity": noise.velocity_mps, "current": noise.current_a}
    sigmas = [sigma.get(kind, 0.0) for _, kind, _ in noisy.model._channels]
    assert sum(s > 0 for s in sigmas) % 2 == 1  # odd: the spare draw crosses frames
    for frame in range(7):
        for d in (noisy, clean):
            d.cmd(d.front[0] + "_joint", ControlMode.POSITION, 0.1 * frame)
            d.run(0.01)
        want = [
            v + reference.gauss(0.0, s) if s > 0 else v
            for v, s in zip(clean.model.reading_values(), sigmas, strict=True)
        ]
        assert noisy.model.reading_values() == want, frame


def test_imu_reads_the_rear_half_attitude() -> None:
    net = network_from_data(
        {
            "name": "tilted",
            "diameter": "63 mm",
            "slope": "20 deg",
            "start": {"roll": "30 deg"},
            "segments": [{"type": "straight", "length": "2 m"}],
        }
    )
    d = Driver(net)  # type: ignore[arg-type]
    readings = d.model.readings()
    assert math.degrees(readings["imu.pitch"]) == pytest.approx(20.0)
    assert math.degrees(readings["imu.roll"]) == pytest.approx(30.0)
    assert math.degrees(readings["imu.yaw"]) == pytest.approx(0.0)
    assert readings["rotation_angle"] == 0.0
