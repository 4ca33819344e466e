"""PIRATE in a pipe: the physics of the simulator, in SI units, with no wire.

The model is deliberately kinematic: it follows the rules of DOMAIN.md ("The
simulator's physical rules") and nothing cleverer, so a tree that passes here
passes because it did what the rules demand. Every number comes from the robot
description (``clamp``, ``motion``, motor limits) or the pipe network.

State:

- ``s`` is the distance of the robot's front tip along the current
  :class:`~pirate_bt.pipes.Path`; each module sits at a fixed offset behind it.
- each half has a roll in the pipe (see conventions below); the rotation sensor
  reads ``roll_front - roll_rear``.
- each motor has a mode and setpoint as the host last sent it; joints track
  position setpoints at their angular-velocity limit and swing toward the wall
  in torque mode until they touch it at ``clamp.contact_angle(diameter)``.

Conventions (also in ``docs/simulator.md``):

- A joint angle is positive when it bends toward the half's *bending
  direction*; the half's roll is the roll of that direction, clockwise from the
  pipe's "up" looking along the travel (0 up, +90° right, 180° down, -90° left).
- A half is *aligned* with a turn of roll ``r`` when its roll is within
  ``motion.alignment_tolerance`` of ``r`` (steer with positive joint angles) or of
  ``r + 180°`` (steer with negative joint angles). It is *steered* when every
  bend joint of the half is at least ``motion.steer_angle`` in that sign.
- Clamping presses the joints toward the wall in either sign; the wall stops
  them at the contact angle.
- The rotational module is rigid with the rear half: the IMU reports the rear
  half's attitude, and rotating moves the front half when the rear is clamped,
  the rear half when the front is clamped.
"""

from __future__ import annotations

import bisect
import logging
import math
import random
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from types import MappingProxyType

from pirate_bt.pipes import Network, Path, Piece, PieceKind, TeeChoice
from pirate_bt.robot.commands import MotorCommand
from pirate_bt.robot.description import (
    ControlMode,
    Half,
    MotorFunction,
    RobotDescription,
    SensorKind,
)
from pirate_bt.sim.counters import EventKind, SimCounters, SimEvent

__all__ = ["HalfTruth", "PipeRobotModel", "SensorNoise", "SimTruth"]

_log = logging.getLogger(__name__)

_GRAVITY_FREE = 1e-9
_CONTACT_EPS_RAD = 0.02
_TORQUE_EPS_NM = 1e-3
_JOINT_FUNCTIONS = (
    MotorFunction.BEND,
    MotorFunction.ROTATE,
    MotorFunction.TILT,
    MotorFunction.CAMERA_TILT,
    MotorFunction.CAMERA_PAN,
)


def _wrap(angle_rad: float) -> float:
    return math.remainder(angle_rad, 2 * math.pi)


@dataclass(frozen=True, slots=True)
class SensorNoise:
    """Standard deviation of the Gaussian noise added to each kind of reading.

    ``SensorNoise()`` is noiseless; :meth:`typical` gives small realistic noise.
    """

    angle_rad: float = 0.0
    force_n: float = 0.0
    velocity_mps: float = 0.0
    """Wheel speed the board's velocity loop drives toward the setpoint."""
    measured_mps: float = 0.0
    """Wheel speed the encoder reads (0 when the wheel is blocked)."""
    current_a: float = 0.0

    @classmethod
    def typical(cls) -> SensorNoise:
        """About one raw step of noise on every reading."""
        return cls(angle_rad=0.002, force_n=0.05, velocity_mps=0.0002, current_a=0.005)


_NO_NOISE = SensorNoise()


class _Zero:
    """Source of a channel that reads 0 (and the slot an IMU channel fills later)."""

    value = 0.0


_ZERO = _Zero()


@dataclass(frozen=True, slots=True)
class HalfTruth:
    """Ground truth of one half.

    Attributes:
        roll_rad: Roll of the half's bending direction in the pipe frame.
        clamped: Every bend joint of the half presses the wall with at least the
            minimum clamp torque.
        normal_force_n: Sum of the wall normal forces of its bend joints.
        stuck: The half is held at the entry of a turn it may not enter.
        segments: Segment id of each of its bend modules.
    """

    roll_rad: float
    clamped: bool
    normal_force_n: float
    stuck: bool
    segments: tuple[str, ...]


@dataclass(frozen=True)
class SimTruth:
    """What really happened, for tests and oracles (not visible to the host).

    Attributes:
        time_s: Simulated time.
        front_m: Distance of the front tip along the path.
        path_choices: The way taken at each tee met so far.
        module_m: Distance of each module's centre along the path.
        module_segment: Segment id each module's centre is in.
        halves: Per-half truth.
        rotation_rad: Angle between the halves (front minus rear).
        joint_angle_rad: Angle of every joint motor (bend, rotate, tilt, cameras).
        velocity_mps: Speed of the robot along the pipe (negative backwards).
        slipping: The wheels turn but the robot does not move for lack of traction.
        sliding: The robot slides back, unclamped in a steep pipe.
        diameter_m: Pipe diameter at the rotational module.
        slope_rad: Pipe slope at the rotational module.
        torque_nm: Torque each torque-limited motor applies now (what the over-torque
            rule looks at).
    """

    time_s: float
    front_m: float
    path_choices: Mapping[str, TeeChoice]
    module_m: Mapping[str, float]
    module_segment: Mapping[str, str]
    halves: Mapping[Half, HalfTruth]
    rotation_rad: float
    joint_angle_rad: Mapping[str, float]
    velocity_mps: float
    slipping: bool
    sliding: bool
    diameter_m: float
    slope_rad: float
    torque_nm: Mapping[str, float]


@dataclass
class _Motor:
    name: str
    function: MotorFunction
    module: str
    mode: ControlMode | None = None
    value: float = 0.0
    angle_rad: float = 0.0
    velocity_mps: float = 0.0
    """Wheel speed the board's velocity loop drives toward the setpoint."""
    measured_mps: float = 0.0
    """Wheel speed the encoder reads (0 when the wheel is blocked)."""
    current_a: float = 0.0
    torque_nm: float = 0.0
    """Torque the motor applies right now (against the wall, or stalled)."""
    press_nm: float = 0.0
    """Torque pressing a bend joint's wheels on the wall (0 when not in contact)."""
    over_since_s: float | None = None
    damaged_this_episode: bool = False
    stalled: bool = False
    angle_min: float = -math.pi
    angle_max: float = math.pi
    rate_max: float = math.pi
    accel_max: float = math.inf
    torque_limit: float = math.inf
    stall_torque: float = 1.0
    settled: tuple[object, ...] | None = None
    """The inputs of a step after which the joint stood still (lets later steps skip it)."""


@dataclass
class _Half:
    half: Half
    joints: list[_Motor]
    drives: list[_Motor]
    lead_offset_m: float
    trail_offset_m: float
    joint_offsets_m: list[float]
    roll_rad: float = 0.0
    clamped: bool = False
    stuck: bool = False
    force_n: float = 0.0
    over_opening: bool = False
    segments: tuple[str, ...] = ()


@dataclass
class _Tally:
    violations: dict[str, int] = field(default_factory=dict)
    damage: dict[str, int] = field(default_factory=dict)
    stuck_events: int = 0
    slip_events: int = 0
    distance_m: float = 0.0
    slide_m: float = 0.0


class PipeRobotModel:
    """The robot in the pipe network, stepped in simulated time.

    Args:
        robot: The robot description (geometry, limits, clamp and motion physics).
        network: The pipe network (the world).
        seed: Seed of the sensor noise; equal seeds give equal runs.
        noise: Sensor noise; noiseless by default.
        start_m: Front-tip distance at the start (default: the network's start
            position, else the robot's length so its rear is at the entry).
    """

    def __init__(
        self,
        robot: RobotDescription,
        network: Network,
        *,
        seed: int = 0,
        noise: SensorNoise | None = None,
        start_m: float | None = None,
    ) -> None:
        self.robot = robot
        self.network = network
        self.noise = noise or SensorNoise()
        self._rng = random.Random(seed)
        self.time_s = 0.0
        self.events: list[SimEvent] = []
        self._tally = _Tally()
        self._choices: dict[str, TeeChoice] = {}
        self.path: Path = network.path(self._choices)
        self._motors: dict[str, _Motor] = {}
        for board, motor in robot.motors():
            m = _Motor(motor.name, motor.function, board.module)
            lim = motor.limits
            if lim.angle is not None:
                m.angle_min, m.angle_max = lim.angle.min, lim.angle.max
            if lim.angular_velocity is not None:
                m.rate_max = lim.angular_velocity.max
            if lim.acceleration is not None:
                m.accel_max = lim.acceleration.max
            if lim.torque is not None:
                m.torque_limit = lim.torque.max
            torque_mode = motor.modes.torque
            if torque_mode is not None:
                m.stall_torque = max(abs(v) for v in torque_mode.si_range)
            self._motors[motor.name] = m
        # geometry: module centres behind the front tip
        self._module_offset: dict[str, float] = {}
        behind = 0.0
        for module in robot.modules:
            self._module_offset[module.name] = behind + module.length / 2
            behind += module.length
        self.length_m = behind
        self._halves: dict[Half, _Half] = {}
        for half in Half:
            members = [m for m in robot.modules if m.half is half]
            lead = min(self._module_offset[m.name] - m.length / 2 for m in members)
            trail = max(self._module_offset[m.name] + m.length / 2 for m in members)
            bends = robot.bend_modules(half)
            joints = [self._motors[robot.joint_motor(b.name).name] for b in bends]
            drives = [
                m
                for m in self._motors.values()
                if m.function is MotorFunction.DRIVE and m.module in {b.name for b in bends}
            ]
            self._halves[half] = _Half(
                half,
                joints,
                drives,
                lead,
                trail,
                [self._module_offset[b.name] for b in bends],
            )
        self._drives = [m for m in self._motors.values() if m.function is MotorFunction.DRIVE]
        self._front = self._halves[Half.FRONT]
        self._rear = self._halves[Half.REAR]
        self._aux_joints = [
            m
            for m in self._motors.values()
            if m.function
            in (MotorFunction.TILT, MotorFunction.CAMERA_TILT, MotorFunction.CAMERA_PAN)
        ]
        self._torqued = [m for m in self._motors.values() if m.torque_limit < math.inf]
        self._rotate = self._motors[robot.rotate_motor().name]
        rot_module = robot.rotational_module().name
        self._rot_offset = self._module_offset[rot_module]
        tilt = [
            m
            for m in self._motors.values()
            if m.function is MotorFunction.TILT and robot.module(m.module).half is Half.FRONT
        ]
        self._front_tilt = tilt[0] if tilt else None
        self._front_pressed_since: float | None = None
        self._channels = self._channel_table()
        self._channel_names = [name for name, _, _ in self._channels]
        self._sources, self._spring_index, self._imu_index = self._reading_sources()
        self._sigmas = [self._sigma(kind) for _, kind, _ in self._channels]
        self._imu_key: tuple[float, float] | None = None
        self._imu_value: dict[str, float] = {}
        self._contact_cache: dict[float, float] = {}
        self._walls: dict[str, float | None] = {}
        self._walls_at = math.nan
        self._walls_path: Path | None = None
        self._wall_spans: dict[str, tuple[float, float]] = {}
        self._slope_cache: dict[int, float] = {}
        self._turns_path: Path | None = None
        self._turns: list[Piece] = []
        self._turn_ends: list[float] = []
        self._tees_path: Path | None = None
        self._tees: list[Piece] = []
        self._tees_calm = (math.inf, -math.inf)
        """An interval of s_m in which no tee changes (see _decide_tees)."""
        start = network.spec.start
        if start_m is None:
            start_m = start.position if start.position is not None else self.length_m
        self.s_m = min(max(start_m, self.length_m), self.path.length_m)
        for h in self._halves.values():
            h.roll_rad = _wrap(start.roll)
        self.velocity_mps = 0.0
        self.slipping = False
        self.sliding = False
        self._rotating_free = False
        self._update_contacts()

    # -- commands -----------------------------------------------------------------

    def command(self, command: MotorCommand) -> None:
        """Apply one SI setpoint, as a PICO board would.

        Raises:
            KeyError: unknown motor.
        """
        m = self._motors[command.motor]
        m.mode = command.mode
        m.value = command.value

    def motors_off(self, names: list[str] | None = None) -> None:
        """Switch motors off (all, or those named): joints go limp, drives stop."""
        for m in self._motors.values():
            if names is None or m.name in names:
                m.mode = None
                m.value = 0.0

    def stop_drives(self) -> None:
        """Set every drive motor's velocity to zero (the watchdog's action)."""
        for m in self._drives:
            m.mode = ControlMode.VELOCITY
            m.value = 0.0

    def set_stalled(self, motor: str, stalled: bool) -> None:
        """Block a motor (fault injection): it neither turns nor moves its joint."""
        self._motors[motor].stalled = stalled

    def half_extent_m(self, half: Half) -> tuple[float, float]:
        """Distances of a half's leading and trailing ends behind the front tip."""
        h = self._halves[half]
        return h.lead_offset_m, h.trail_offset_m

    def motor_names(self) -> list[str]:
        return list(self._motors)

    # -- stepping -----------------------------------------------------------------

    def step(self, dt_s: float) -> None:
        """Advance the world by ``dt_s`` seconds (call with small steps, e.g. 10 ms)."""
        if dt_s <= 0:
            return
        self.time_s += dt_s
        self._update_walls()
        if self._step_joints(dt_s):
            self._update_contacts()
        self._step_rotation(dt_s)
        self._step_drives(dt_s)
        before = self.s_m
        self._step_motion(dt_s)
        if self.s_m != before and self._update_walls():
            self._contacts()
        self._check_torques()

    def _joint_target(self, m: _Motor) -> tuple[float, float]:
        """(target angle, applied torque if it reaches the target) for a joint motor."""
        if m.mode is ControlMode.POSITION:
            return min(max(m.value, m.angle_min), m.angle_max), 0.0
        if m.mode is ControlMode.TORQUE:
            if abs(m.value) < _TORQUE_EPS_NM:
                return m.angle_rad, 0.0
            return (m.angle_max if m.value > 0 else m.angle_min), abs(m.value)
        if m.mode is ControlMode.PWM:
            if m.value == 0:
                return m.angle_rad, 0.0
            torque = abs(m.value) * m.stall_torque
            return (m.angle_max if m.value > 0 else m.angle_min), torque
        return m.angle_rad, 0.0  # off: limp, the gears hold the angle

    def _step_joints(self, dt_s: float) -> bool:
        """Step every joint; True when a bend joint may have changed (contacts need a look)."""
        hold = self.robot.motion.position_hold_torque
        changed = False
        for half in self._halves.values():
            for j in half.joints:
                wall = self._walls[j.name]
                key = (j.mode, j.value, wall, j.angle_rad, j.stalled)
                if key == j.settled:
                    continue  # nothing moved and nothing changed since the last step
                changed = True
                target, torque = self._joint_target(j)
                if j.stalled:
                    # Blocked where it stands, but the board still closes its loop: in
                    # torque mode the motor applies the commanded torque (PWM: its share
                    # of the stall torque), so a stall alone is no over-torque. Only a
                    # position loop that cannot reach its setpoint saturates.
                    if j.mode is ControlMode.POSITION:
                        j.torque_nm = j.stall_torque if target != j.angle_rad else 0.0
                    else:
                        j.torque_nm = torque
                    j.press_nm = 0.0
                    continue
                limit = wall if wall is not None else math.inf
                # the wall stops the joint at +-wall
                blocked_target = min(max(target, -limit), limit)
                step = j.rate_max * dt_s
                delta = blocked_target - j.angle_rad
                j.angle_rad += max(-step, min(step, delta))
                pushing_wall = (
                    wall is not None
                    and abs(j.angle_rad) >= wall - 1e-9
                    and abs(target) > wall + 1e-9
                    and target * j.angle_rad > 0
                )
                if pushing_wall:
                    press = torque if j.mode is not ControlMode.POSITION else hold
                    j.press_nm = press
                    j.torque_nm = press
                else:
                    j.press_nm = 0.0
                    j.torque_nm = torque if j.mode is not ControlMode.POSITION else 0.0
                if j.angle_rad == blocked_target:
                    j.settled = (j.mode, j.value, wall, j.angle_rad, j.stalled)
        for m in self._aux_joints:
            if m.stalled or (m.mode is None and m.torque_nm == 0.0):
                continue
            target, torque = self._joint_target(m)
            step = m.rate_max * dt_s
            m.angle_rad += max(-step, min(step, target - m.angle_rad))
            m.torque_nm = torque
        return changed

    def _wall_angle(self, s_m: float) -> float | None:
        """Joint angle at which the wheels touch the wall at ``s_m``; None over a tee opening."""
        piece = self.path.piece_at(s_m)
        if piece.opening_m is not None and piece.over_opening(s_m):
            return None
        diameter = piece.diameter_at(s_m)
        angle = self._contact_cache.get(diameter)
        if angle is None:
            angle = self._contact_cache[diameter] = self.robot.clamp.contact_angle(diameter)
        return angle

    def _update_walls(self) -> bool:
        """Recompute the wall angle under each bend joint; True when one changed."""
        if self.s_m == self._walls_at and self.path is self._walls_path:
            return False
        changed = False
        self._walls_at = self.s_m
        path_changed = self.path is not self._walls_path
        self._walls_path = self.path
        spans = self._wall_spans
        for half in self._halves.values():
            for j, off in zip(half.joints, half.joint_offsets_m, strict=True):
                at = self.s_m - off
                span = spans.get(j.name)
                if not path_changed and span is not None and span[0] <= at < span[1]:
                    continue  # same plain piece of constant diameter: same wall
                wall = self._wall_angle(at)
                if wall != self._walls.get(j.name, math.nan):
                    changed = True
                self._walls[j.name] = wall
                piece = self.path.piece_at(at)
                plain = piece.opening_m is None and piece.diameter_start_m == piece.diameter_end_m
                spans[j.name] = (piece.start_m, piece.end_m) if plain else (0.0, 0.0)
        return changed or path_changed

    def _update_contacts(self) -> None:
        self._update_walls()
        self._contacts()

    def _contacts(self) -> None:
        clamp = self.robot.clamp
        lever = clamp.lever_arm
        for half in self._halves.values():
            force = 0.0
            ok = bool(half.joints)
            sign = 0.0
            opening = False
            for j in half.joints:
                if self._walls[j.name] is None:
                    opening = True
                force += j.press_nm / lever
                if not clamp.holds(j.press_nm):
                    ok = False
                if sign == 0.0:
                    sign = math.copysign(1.0, j.angle_rad)
                elif sign * j.angle_rad < 0:
                    ok = False
            half.force_n = force
            half.clamped = ok and not opening
            half.over_opening = opening

    def _step_rotation(self, dt_s: float) -> None:
        m = self._rotate
        front, rear = self._halves[Half.FRONT], self._halves[Half.REAR]
        target, torque = self._joint_target(m)
        delta = target - m.angle_rad
        moving = abs(delta) > 1e-9 and not m.stalled
        if front.clamped and rear.clamped and moving:
            m.torque_nm = max(torque, m.stall_torque)  # both halves held: the motor stalls
            self._rotating_free = False
            return
        m.torque_nm = torque if moving else 0.0
        if not moving:
            self._rotating_free = False
            return
        step = m.rate_max * dt_s
        d = max(-step, min(step, delta))
        m.angle_rad += d
        if front.clamped:
            rear.roll_rad = _wrap(rear.roll_rad - d)
            self._rotating_free = False
        elif rear.clamped:
            front.roll_rad = _wrap(front.roll_rad + d)
            self._rotating_free = False
        else:
            front.roll_rad = _wrap(front.roll_rad + d / 2)
            rear.roll_rad = _wrap(rear.roll_rad - d / 2)
            if not self._rotating_free:
                self._violation("uncontrolled_rotation", "rotated with no half clamped")
            self._rotating_free = True

    def _step_drives(self, dt_s: float) -> None:
        for m in self._drives:
            mode = m.mode
            if mode is ControlMode.VELOCITY:
                target = m.value
            elif mode is ControlMode.PWM:
                target = m.value * self.robot.motion.nominal_speed
            else:
                target = 0.0
            if m.stalled:
                target = 0.0
            delta = target - m.velocity_mps
            if delta == 0.0:
                continue
            step = m.accel_max * dt_s
            m.velocity_mps = (
                target
                if -step <= delta <= step
                else m.velocity_mps + (step if delta > 0 else -step)
            )

    def _step_motion(self, dt_s: float) -> None:
        motion = self.robot.motion
        front, rear = self._front, self._rear
        clamped = [h for h in (front, rear) if h.clamped]
        v_sum = 0.0
        n_wheels = 0
        for h in clamped:
            for m in h.drives:
                if not m.stalled:
                    v_sum += m.velocity_mps
                    n_wheels += 1
        v_cmd = v_sum / n_wheels if n_wheels else 0.0
        any_cmd = False
        for m in self._drives:
            if m.velocity_mps > 1e-6 or m.velocity_mps < -1e-6:
                any_cmd = True
                break
        moved = 0.0
        was_sliding, was_slipping = self.sliding, self.slipping
        self.sliding = False
        self.slipping = False
        stuck_front = stuck_rear = False
        load_ratio = 0.0
        if not clamped:
            slope = self._slope_at(self.s_m - self._rot_offset)
            if abs(slope) > motion.max_unclamped_slope:
                self.sliding = True
                direction = -1.0 if slope > 0 else 1.0
                moved = self._limit_to_path(direction * motion.slide_speed * dt_s)
                self._tally.slide_m += abs(moved)
                if not was_sliding:
                    self._violation(
                        "sliding", f"unclamped on a {math.degrees(slope):.0f} deg slope"
                    )
            elif any_cmd:
                self.slipping = True
        elif v_cmd > 1e-9 or v_cmd < -1e-9:
            slope = self._slope_at(self.s_m - self._rot_offset)
            traction = motion.friction_coefficient * sum(h.force_n for h in clamped)
            load = motion.weight * math.sin(slope) * (1.0 if v_cmd > 0 else -1.0)
            if v_cmd > 0:
                load += self.network.tether_drag_per_m * max(self.s_m - self.length_m, 0.0)
            load_ratio = max(load, 0.0) / traction if traction > 0 else 1.0
            if traction <= load:
                self.slipping = True
            else:
                moved, stuck_front, stuck_rear = self._gate_turns(v_cmd * dt_s)
                moved = self._limit_to_path(moved)
        self.velocity_mps = moved / dt_s
        if moved:
            self.s_m += moved
            self._tally.distance_m += abs(moved)
        if self.slipping and not was_slipping:
            self._tally.slip_events += 1
            self._event(EventKind.SLIP, f"traction too low at {self.s_m:.3f} m")
        for half, now in ((front, stuck_front), (rear, stuck_rear)):
            if now and not half.stuck:
                self._tally.stuck_events += 1
                point = self.s_m - (half.lead_offset_m if v_cmd > 0 else half.trail_offset_m)
                piece = self.path.next_turn(point - 1e-9) if v_cmd > 0 else None
                if piece is None:
                    turns = self._turns_between(point - 1e-6, point + 1e-6)
                    piece = turns[0] if turns else None
                where = piece.segment if piece is not None else "?"
                self._event(EventKind.STUCK, f"{half.half}:{where}")
                _log.info("%s half stuck at %s", half.half, where)
            half.stuck = now
        if (self._tees and moved) or self._tees_path is not self.path:
            self._decide_tees()
        self._drive_feedback(load_ratio, stuck_front or stuck_rear)

    def _slope_at(self, s_m: float) -> float:
        piece = self.path.piece_at(s_m)
        if piece.is_turn:
            return self.path.slope_at(s_m)
        slope = self._slope_cache.get(id(piece))
        if slope is None:
            slope = self._slope_cache[id(piece)] = self.path.slope_at(s_m)
        return slope

    def _limit_to_path(self, ds: float) -> float:
        lo = self.length_m
        hi = self.path.length_m
        return min(max(self.s_m + ds, lo), hi) - self.s_m

    def _gate_turns(self, ds: float) -> tuple[float, bool, bool]:
        """Limit a move so that no half enters or moves in a turn it may not use.

        Returns:
            ``(allowed move, front stuck, rear stuck)``.
        """
        stuck = [False, False]
        allowed = ds
        for i, half in enumerate((self._front, self._rear)):
            point = self.s_m - (half.lead_offset_m if ds > 0 else half.trail_offset_m)
            target = point + ds
            lo, hi = (point, target) if ds > 0 else (target, point)
            for piece in self._turns_between(lo, hi):
                if self._may_use_turn(half, piece):
                    continue
                edge = piece.start_m if ds > 0 else piece.end_m
                if (ds > 0 and point >= edge) or (ds < 0 and point <= edge):
                    # already inside and no longer allowed: stop where it is
                    limit = 0.0
                else:
                    limit = edge - point
                if abs(limit) < abs(allowed):
                    allowed = limit
                stuck[i] = True
                break
        return allowed, stuck[0], stuck[1]

    def _turns_between(self, lo: float, hi: float) -> list[Piece]:
        if self._turns_path is not self.path:
            self._turns_path = self.path
            self._turns = [p for p in self.path.pieces if p.is_turn]
            self._turn_ends = [p.end_m for p in self._turns]
        out: list[Piece] = []
        for piece in self._turns[bisect.bisect_right(self._turn_ends, lo) :]:
            if piece.start_m >= hi:
                break
            out.append(piece)
        return out

    def _may_use_turn(self, half: _Half, piece: Piece) -> bool:
        if half.clamped:
            return False
        sign = self._aligned_sign(half.roll_rad, piece.roll_rad)
        if sign == 0:
            return False
        steer = self.robot.motion.steer_angle
        return all(j.angle_rad * sign >= steer - 1e-9 for j in half.joints)

    def _aligned_sign(self, half_roll: float, turn_roll: float) -> int:
        tol = self.robot.motion.alignment_tolerance
        if abs(_wrap(half_roll - turn_roll)) <= tol:
            return 1
        if abs(_wrap(half_roll - turn_roll - math.pi)) <= tol:
            return -1
        return 0

    def _decide_tees(self) -> None:
        """Choose straight or branch when the front tip passes the middle of a tee."""
        changed = False
        if self._tees_path is not self.path:
            self._tees_path = self.path
            self._tees = [p for p in self.path.pieces if p.opening_m is not None]
            self._tees_calm = (math.inf, -math.inf)
        low, high = self._tees_calm
        if low <= self.s_m < high:
            return  # no tee can be decided or undecided until s_m leaves [low, high)
        for piece in self._tees:
            assert piece.opening_m is not None
            decided = piece.segment in self._choices
            if decided and self.s_m < piece.opening_m - 1e-9:
                # backed out before the opening: the tee is undecided again
                del self._choices[piece.segment]
                changed = True
            elif not decided and self.s_m >= piece.opening_m + 1e-9:
                fake = replace(piece, kind=PieceKind.TEE_TURN)
                front = self._halves[Half.FRONT]
                choice: TeeChoice = "branch" if self._may_use_turn(front, fake) else "straight"
                self._choices[piece.segment] = choice
                self._event(EventKind.TEE, f"{piece.segment}:{choice}")
                changed = True
                if choice == "branch":
                    self.s_m = piece.opening_m
                break
        if changed:
            self.path = self.network.path(self._choices)
            self._tees_calm = (math.inf, -math.inf)
        else:
            # Nothing changed at s_m: nothing will while s_m stays above the opening of
            # every tee decided and below that of every tee undecided (this method is
            # the only one that changes the choices; a new path resets the interval).
            low, high = -math.inf, math.inf
            for piece in self._tees:
                assert piece.opening_m is not None
                if piece.segment in self._choices:
                    low = max(low, piece.opening_m - 1e-9)
                else:
                    high = min(high, piece.opening_m + 1e-9)
            self._tees_calm = (low, high)

    def _drive_feedback(self, load_ratio: float, stuck: bool) -> None:
        motion = self.robot.motion
        free, stall = motion.drive_free_current, motion.drive_stall_current
        slipping = self.slipping
        for m in self._drives:
            v = m.velocity_mps
            if m.stalled:
                m.current_a = stall if (m.mode is not None and m.value != 0) else 0.0
                m.velocity_mps = m.measured_mps = 0.0
            elif -1e-6 < v < 1e-6:
                m.current_a = 0.0
                m.measured_mps = v
            elif stuck:
                m.current_a = stall  # blocked wheels: no speed, stall current
                m.measured_mps = 0.0
            elif slipping:
                m.current_a = free
                m.measured_mps = v
            else:
                m.current_a = free + (stall - free) * min(load_ratio, 1.0)
                m.measured_mps = v

    def _check_torques(self) -> None:
        over_time = self.robot.motion.over_torque_time
        for m in self._torqued:
            if m.torque_nm > m.torque_limit + 1e-9:
                if m.over_since_s is None:
                    m.over_since_s = self.time_s
                elif self.time_s - m.over_since_s >= over_time and not m.damaged_this_episode:
                    m.damaged_this_episode = True
                    self._damage(f"over_torque:{m.name}", f"{m.torque_nm:.2f} N*m")
            else:
                m.over_since_s = None
                m.damaged_this_episode = False
        # the front module in the way of a front clamp
        front = self._halves[Half.FRONT]
        tilt = self._front_tilt
        pressing = any(j.press_nm > 0 for j in front.joints)
        clear = tilt is None or abs(tilt.angle_rad) >= self.robot.clamp.front_clear_angle - 1e-9
        if pressing and not clear:
            if self._front_pressed_since is None:
                self._front_pressed_since = self.time_s
            elif self.time_s - self._front_pressed_since >= over_time:
                self._damage("front_pressed", "front half clamped with the front module in the way")
                self._front_pressed_since = math.inf
        else:
            self._front_pressed_since = None

    # -- events ---------------------------------------------------------------------

    def _event(self, kind: EventKind, detail: str) -> None:
        self.events.append(SimEvent(self.time_s, kind, detail))

    def _violation(self, kind: str, detail: str) -> None:
        self._tally.violations[kind] = self._tally.violations.get(kind, 0) + 1
        self._event(EventKind.VIOLATION, f"{kind}: {detail}")
        _log.warning("violation %s: %s", kind, detail)

    def _damage(self, kind: str, detail: str) -> None:
        self._tally.damage[kind] = self._tally.damage.get(kind, 0) + 1
        self._event(EventKind.DAMAGE, f"{kind}: {detail}")
        _log.warning("damage %s: %s", kind, detail)

    def record(self, kind: EventKind, detail: str) -> None:
        """Add an event from outside the physics (faults, watchdog)."""
        self._event(kind, detail)

    def counters(self) -> SimCounters:
        """The physics counters (the bridge adds the link counters)."""
        t = self._tally
        return SimCounters(
            violations=MappingProxyType(dict(t.violations)),
            damage=MappingProxyType(dict(t.damage)),
            stuck_events=t.stuck_events,
            slip_events=t.slip_events,
            distance_m=t.distance_m,
            slide_m=t.slide_m,
        )

    # -- readings -------------------------------------------------------------------

    def _channel_table(self) -> list[tuple[str, str, str]]:
        """(channel, source kind, source name) for every state channel."""
        robot = self.robot
        table: list[tuple[str, str, str]] = []
        spring_of: dict[str, str] = {}
        angle_of: dict[str, str] = {}
        for board in robot.boards:
            for sensor in board.sensors:
                if sensor.kind is SensorKind.SPRING:
                    spring_of[sensor.name] = board.module
                elif sensor.kind is SensorKind.ANGLE:
                    motor = next((m for m in board.motors if m.slot == sensor.slot), None)
                    if motor is not None and motor.function in _JOINT_FUNCTIONS:
                        angle_of[sensor.name] = motor.name
        imu = robot.imu()
        for spec in robot.state_channels():
            name = spec.name
            if name in angle_of:
                table.append((name, "angle", angle_of[name]))
            elif name in spring_of:
                module = spring_of[name]
                table.append((name, "spring", robot.joint_motor(module).name))
            elif imu is not None and name.startswith(f"{imu.name}."):
                table.append((name, "imu", name.split(".", 1)[1]))
            elif name.endswith(".velocity"):
                table.append((name, "velocity", name.rsplit(".", 1)[0]))
            elif name.endswith(".current"):
                table.append((name, "current", name.rsplit(".", 1)[0]))
            else:
                table.append((name, "zero", ""))
        return table

    def _imu(self) -> dict[str, float]:
        s = self.s_m - self._rot_offset
        tangent, up = self.path.frame_at(s)
        roll = self._halves[Half.REAR].roll_rad
        right = (
            tangent[1] * up[2] - tangent[2] * up[1],
            tangent[2] * up[0] - tangent[0] * up[2],
            tangent[0] * up[1] - tangent[1] * up[0],
        )
        b = tuple(math.cos(roll) * u + math.sin(roll) * r for u, r in zip(up, right, strict=True))
        pitch = math.asin(max(-1.0, min(1.0, tangent[2])))
        zt = tangent[2]
        zp = (-zt * tangent[0], -zt * tangent[1], 1.0 - zt * tangent[2])
        n = math.sqrt(zp[0] ** 2 + zp[1] ** 2 + zp[2] ** 2)
        if n < 1e-6:
            imu_roll = roll
        else:
            zp = (zp[0] / n, zp[1] / n, zp[2] / n)
            rg = (
                tangent[1] * zp[2] - tangent[2] * zp[1],
                tangent[2] * zp[0] - tangent[0] * zp[2],
                tangent[0] * zp[1] - tangent[1] * zp[0],
            )
            imu_roll = math.atan2(
                b[0] * rg[0] + b[1] * rg[1] + b[2] * rg[2],
                b[0] * zp[0] + b[1] * zp[1] + b[2] * zp[2],
            )
        yaw = math.atan2(tangent[1], tangent[0]) if abs(zt) < 1 - 1e-9 else 0.0
        return {"roll": imu_roll, "pitch": pitch, "yaw": yaw}

    def readings(self) -> dict[str, float]:
        """Every state channel's SI value (with noise), by channel name."""
        return dict(zip(self._channel_names, self.reading_values(), strict=True))

    def reading_values(self) -> list[float]:
        """Every state channel's SI value (with noise), in the state frame's channel order."""
        # Called once per state period: plain attribute reads in one comprehension (no
        # Python call per channel), then the few channels that need arithmetic.
        values = [getattr(obj, attr) for obj, attr in self._sources]
        lever = self.robot.clamp.lever_arm
        for i in self._spring_index:
            values[i] = values[i] / lever  # press torque -> normal force
        if self._imu_index:
            imu = self._imu_cached()
            for i, key in self._imu_index:
                values[i] = imu.get(key, 0.0)
        if self.noise != _NO_NOISE:
            gauss = self._rng.gauss
            values = [
                v + gauss(0.0, sigma) if sigma > 0 else v
                for v, sigma in zip(values, self._sigmas, strict=True)
            ]
        return values

    def _reading_sources(
        self,
    ) -> tuple[list[tuple[object, str]], list[int], list[tuple[int, str]]]:
        """(object, attribute) read for each channel; spring and IMU channel indices."""
        sources: list[tuple[object, str]] = []
        springs: list[int] = []
        imu: list[tuple[int, str]] = []
        attr = {"angle": "angle_rad", "velocity": "measured_mps", "current": "current_a"}
        for i, (_, kind, source) in enumerate(self._channels):
            if kind == "imu":
                imu.append((i, source))
                sources.append((_ZERO, "value"))
            elif kind == "zero":
                sources.append((_ZERO, "value"))
            elif kind == "spring":
                springs.append(i)
                sources.append((self._motors[source], "press_nm"))
            else:
                sources.append((self._motors[source], attr[kind]))
        return sources, springs, imu

    def _sigma(self, kind: str) -> float:
        noise = self.noise
        return {
            "angle": noise.angle_rad,
            "imu": noise.angle_rad,
            "spring": noise.force_n,
            "velocity": noise.velocity_mps,
            "current": noise.current_a,
        }.get(kind, 0.0)

    def _imu_cached(self) -> dict[str, float]:
        s = self.s_m - self._rot_offset
        piece = self.path.piece_at(s)
        key = (id(piece) if not piece.is_turn else s, self._rear.roll_rad)
        if key != self._imu_key:
            self._imu_key = key
            self._imu_value = self._imu()
        return self._imu_value

    # -- truth ----------------------------------------------------------------------

    def truth(self) -> SimTruth:
        """Ground truth now (a fresh immutable snapshot)."""
        path = self.path
        module_m = {name: self.s_m - off for name, off in self._module_offset.items()}
        module_segment = {name: path.piece_at(s).segment for name, s in module_m.items()}
        halves = {
            h.half: HalfTruth(
                roll_rad=h.roll_rad,
                clamped=h.clamped,
                normal_force_n=h.force_n,
                stuck=h.stuck,
                segments=tuple(path.piece_at(self.s_m - off).segment for off in h.joint_offsets_m),
            )
            for h in self._halves.values()
        }
        s_rot = self.s_m - self._rot_offset
        return SimTruth(
            time_s=self.time_s,
            front_m=self.s_m,
            path_choices=MappingProxyType(dict(self._choices)),
            module_m=MappingProxyType(module_m),
            module_segment=MappingProxyType(module_segment),
            halves=MappingProxyType(halves),
            rotation_rad=self._rotate.angle_rad,
            joint_angle_rad=MappingProxyType(
                {
                    m.name: m.angle_rad
                    for m in self._motors.values()
                    if m.function in _JOINT_FUNCTIONS
                }
            ),
            velocity_mps=self.velocity_mps,
            slipping=self.slipping,
            sliding=self.sliding,
            diameter_m=path.diameter_at(s_rot),
            slope_rad=path.slope_at(s_rot),
            torque_nm=MappingProxyType({m.name: m.torque_nm for m in self._torqued}),
        )
