"""PIRATE in a pipe: the physics of the simulator, in SI units, with no wire.

The rules live in mixins, one module per seam (add a physical rule where it belongs):

- :mod:`pirate_bt.sim.model_types`: the state and truth types (``_Motor``,
  ``_Half``, :class:`SensorNoise`, :class:`SimTruth`...) and shared constants.
- :mod:`pirate_bt.sim.model_joints`: joints, walls and clamps, the rotational
  module, the over-torque and front-module damage rules.
- :mod:`pirate_bt.sim.model_motion`: drives, traction, slipping and sliding, turn
  gating, tee choices, wheel speed and current.
- :mod:`pirate_bt.sim.model_readings`: the state channels, the IMU, sensor noise.
- :mod:`pirate_bt.sim.model_events`: events, violations, damage, the counters.

This module keeps :class:`PipeRobotModel` itself: its construction, the commands,
the order of :meth:`~PipeRobotModel.step`, and :meth:`~PipeRobotModel.truth`.

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

import math
import random
from collections.abc import Sequence
from types import MappingProxyType

from pirate_bt.errors import ConfigurationError, InputError
from pirate_bt.pipes import Network, Path, Piece, TeeChoice
from pirate_bt.pipes.loader import network_place
from pirate_bt.pipes.model import SegmentSpec, TeeSpec
from pirate_bt.robot.commands import MotorCommand
from pirate_bt.robot.description import (
    ControlMode,
    Half,
    MotorFunction,
    RobotDescription,
)
from pirate_bt.sim.counters import SimEvent
from pirate_bt.sim.model_events import EventsMixin
from pirate_bt.sim.model_joints import JointsMixin
from pirate_bt.sim.model_motion import MotionMixin
from pirate_bt.sim.model_readings import ReadingsMixin
from pirate_bt.sim.model_types import (
    _JOINT_FUNCTIONS,
    HalfTruth,
    SensorNoise,
    SimTruth,
    _Half,
    _Motor,
    _Tally,
    _wrap,
)

__all__ = ["HalfTruth", "PipeRobotModel", "SensorNoise", "SimTruth"]


def _check_diameters(robot: RobotDescription, network: Network) -> None:
    """Refuse a pipe narrower than the robot's wall-contact table: it does not fit.

    A pipe wider than the table is simulated: the wheels never reach its wall
    (:meth:`PipeRobotModel._wall_angle`), so the robot cannot clamp there. The refusal
    is said at the diameter's ``file:line:column`` in the network's file (before
    2026-11-30 it named the segment alone, no file).

    Raises:
        ConfigurationError: the network, a straight or a reducer is narrower than the
            table's smallest diameter.
    """
    low = min(p.diameter for p in robot.clamp.contact_angles)

    def check(d: float, where: str, key: tuple[str | int, ...]) -> None:
        if d < low - 1e-9:
            place = network_place(network, key)
            raise ConfigurationError(
                ("" if place is None else f"{place}: ")
                + f"pipe network {network.name!r}: {where} is {d * 1000:g} mm wide, but the"
                f" robot fits only in pipes of {low * 1000:g} mm and more (its"
                " clamp.contact_angles)"
            )

    def walk(segments: Sequence[SegmentSpec], prefix: str, key: tuple[str | int, ...]) -> None:
        for i, seg in enumerate(segments):
            name = seg.id or f"{prefix}-{i + 1}"
            if isinstance(seg, TeeSpec):
                walk(seg.branch.segments, f"{name}-b", (*key, i, "branch", "segments"))
            elif seg.type != "bend" and seg.diameter is not None:
                check(seg.diameter, f"segment {name!r}", (*key, i, "diameter"))

    check(network.spec.diameter, "the start of its main line", ("diameter",))
    walk(network.spec.segments, "main", ("segments",))


class PipeRobotModel(JointsMixin, MotionMixin, ReadingsMixin, EventsMixin):
    """The robot in the pipe network, stepped in simulated time.

    Args:
        robot: The robot description (geometry, limits, clamp and motion physics).
        network: The pipe network (the world).
        seed: Seed of the sensor noise; equal seeds give equal runs.
        noise: Sensor noise; noiseless by default.
        start_m: Front-tip distance at the start (default: the network's start
            position, else the robot's length so its rear is at the entry), in
            metres, kept between the robot's length and the path's end.

    Raises:
        InputError: ``start_m`` that is no finite number of metres.
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
        self._gauss_spare: float | None = None  # the noise's Box-Muller spare draw
        self.time_s = 0.0
        self.events: list[SimEvent] = []
        self._tally = _Tally()
        self._choices: dict[str, TeeChoice] = {}
        self.path: Path = network.path(self._choices)
        _check_diameters(robot, network)
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
        self._module_offset = robot.behind_front_tip_m()
        self.length_m = sum(module.length for module in robot.modules)
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
        elif (
            isinstance(start_m, bool)
            or not isinstance(start_m, int | float)
            or not math.isfinite(start_m)
        ):  # nan put the robot nowhere and ran on; text raised a TypeError
            raise InputError(
                f"start_m: the front tip's distance is a finite number of metres, not {start_m!r}"
            )
        self.s_m = min(max(start_m, self.length_m), self.path.length_m)
        for h in self._halves.values():
            h.roll_rad = _wrap(start.roll)
        self.velocity_mps = 0.0
        self.slipping = False
        self.sliding = False
        self.held_as_put_in = True
        """Held on its tether where it was put in, as an operator holds a robot until
        it clamps: no slide until a half first clamps (then the falling rule applies)."""
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

    def setpoint(self, motor: str) -> MotorCommand | None:
        """The setpoint ``motor`` holds now, or ``None`` when it is off.

        Raises:
            KeyError: unknown motor.
        """
        m = self._motors[motor]
        return None if m.mode is None else MotorCommand(m.name, m.mode, m.value)

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
