"""A fake :class:`~pirate_bt.robot.port.RobotPort` for tests of the protective layer.

:class:`FakePort` holds a state you set by channel name (``port.set(bend_1_angle=1.5)``)
or by situation (:meth:`FakePort.clamp_half`, :meth:`FakePort.set_pitch`), stamps it
with the shared clock, and records what was sent. With ``physics=True`` it
also plays a crude robot: setpoints take effect at once (a clamp torque puts the
joints at the wall and the springs at ``torque / lever_arm``), so sequences of
commands can be tested, and it counts the violations of DOMAIN.md's rules that
the supervisor exists to prevent (rotating with none or both halves clamped,
both halves unclamped in a steep pipe, a torque above a motor's limit).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

from pirate_bt.clock import Clock
from pirate_bt.errors import LinkError
from pirate_bt.robot.commands import MotorCommand
from pirate_bt.robot.description import (
    ControlMode,
    Half,
    MotorFunction,
    RobotDescription,
    SensorKind,
)
from pirate_bt.robot.port import LinkHealth
from pirate_bt.robot.state import Reading, RobotState, StateBuilder
from pirate_bt.safety.checks import front_tilt_channel

__all__ = ["FakePort", "FakeViolations"]


@dataclass
class FakeViolations:
    """What the fake robot counted (physics mode only)."""

    events: list[str] = field(default_factory=list)

    def __len__(self) -> int:
        return len(self.events)


class FakePort:
    """An in-memory robot port; every reading is fresh at the clock's current time.

    Args:
        robot: The robot description.
        clock: The shared clock (a :class:`~pirate_bt.clock.SimClock` in tests).
        physics: Apply setpoints to the state at once and count violations.
        diameter_m: Pipe diameter the fake clamps in (sets the wall-contact angle).
    """

    def __init__(
        self,
        robot: RobotDescription,
        clock: Clock,
        *,
        physics: bool = False,
        diameter_m: float = 0.063,
    ) -> None:
        self._robot = robot
        self.clock = clock
        self.physics = physics
        self.diameter_m = diameter_m
        self.builder = StateBuilder(robot)
        self.values: dict[str, float] = {}
        self.stamps: dict[str, float] = {}
        self.sent: list[MotorCommand] = []
        self.batches: list[tuple[MotorCommand, ...]] = []
        self.estops = 0
        self.estopped = False
        self.connected = True
        self.faulted_boards: tuple[int, ...] = ()  # boards reporting FAULT
        self.bus_fault = False  # the bridge reporting BUS_FAULT
        self.fail_send = False
        self.poll_error: LinkError | None = None
        self.last_heard_s: float | None = None
        self.frozen: set[str] = set()
        self.violations = FakeViolations()
        self.setpoints: dict[str, tuple[ControlMode, float]] = {}
        self.closed = False
        self._joint_sensor = {
            m.name: robot.sensor_of(m.name, SensorKind.ANGLE).name for m in robot.all_bend_modules()
        }
        self._spring_sensor: dict[str, str] = {}
        for m in robot.all_bend_modules():
            try:
                self._spring_sensor[m.name] = robot.sensor_of(m.name, SensorKind.SPRING).name
            except KeyError:
                continue
        self.tilt_channel = front_tilt_channel(robot)
        self.rotation_channel = robot.sensor_of(
            robot.rotational_module().name, SensorKind.ANGLE
        ).name
        imu = robot.imu()
        self.imu_prefix = imu.name if imu is not None else None
        self.reset_values()

    # -- set-up helpers -----------------------------------------------------

    def reset_values(self) -> None:
        """Both halves free and straight, level pipe, front module clear, nothing moving."""
        for ch in self.builder.channel_names:
            self.values[ch] = 0.0
        if self.tilt_channel is not None:
            self.values[self.tilt_channel] = self._robot.clamp.front_clear_angle

    def set(self, **values: float) -> None:
        """Set channels by name; use ``imu__pitch`` for ``imu.pitch`` (dots as ``__``)."""
        for key, value in values.items():
            self.values[key.replace("__", ".")] = value

    def set_pitch(self, pitch_rad: float) -> None:
        if self.imu_prefix is not None:
            self.values[f"{self.imu_prefix}.pitch"] = pitch_rad

    def set_tilt(self, tilt_rad: float) -> None:
        if self.tilt_channel is not None:
            self.values[self.tilt_channel] = tilt_rad

    def clamp_half(self, half: Half, torque_nm: float | None = None) -> None:
        """Put a half at the wall with springs at the force ``torque_nm`` makes."""
        torque = self._robot.clamp.min_torque * 1.5 if torque_nm is None else torque_nm
        angle = self._robot.clamp.contact_angle(self.diameter_m)
        for m in self._robot.bend_modules(half):
            self.values[self._joint_sensor[m.name]] = angle
            if m.name in self._spring_sensor:
                self.values[self._spring_sensor[m.name]] = torque / self._robot.clamp.lever_arm

    def free_half(self, half: Half, angle_rad: float = 0.0) -> None:
        """Put a half's joints at ``angle_rad`` with no force on the wall."""
        for m in self._robot.bend_modules(half):
            self.values[self._joint_sensor[m.name]] = angle_rad
            if m.name in self._spring_sensor:
                self.values[self._spring_sensor[m.name]] = 0.0

    def half_between(self, half: Half) -> None:
        """Joints half-way to the wall with a little force: neither clamped nor free."""
        angle = self._robot.clamp.contact_angle(self.diameter_m) * 0.6
        force = 0.5 * self._robot.clamp.min_torque / self._robot.clamp.lever_arm
        for m in self._robot.bend_modules(half):
            self.values[self._joint_sensor[m.name]] = angle
            if m.name in self._spring_sensor:
                self.values[self._spring_sensor[m.name]] = force

    def freeze(self, *channels: str) -> None:
        """Stop refreshing ``channels``: they keep their last stamp and go stale."""
        now = self.clock.now()
        for ch in channels:
            self.stamps.setdefault(ch, now)
            self.frozen.add(ch)

    # -- RobotPort -------------------------------------------------------------

    @property
    def robot(self) -> RobotDescription:
        return self._robot

    def poll(self) -> None:
        if self.poll_error is not None:
            raise self.poll_error

    def state(self) -> RobotState | None:
        now = self.clock.now()
        readings: dict[str, Reading] = {}
        for name, value in self.values.items():
            stamp = self.stamps[name] if name in self.frozen else now
            readings[name] = Reading(value, stamp)
        return self.builder.from_readings(readings, now)

    def send(self, commands: Sequence[MotorCommand]) -> None:
        if self.fail_send or not self.connected:
            raise LinkError("fake send failure")
        batch = tuple(commands)
        self.batches.append(batch)
        self.sent.extend(batch)
        for c in batch:
            self.setpoints[c.motor] = (c.mode, c.value)
        if self.physics:
            self._apply(batch)

    def estop(self) -> None:
        self.estops += 1
        self.estopped = True
        for m in self._robot.drive_motors():
            self.setpoints[m.name] = (ControlMode.VELOCITY, 0.0)

    def reset_estop(self) -> None:
        self.estopped = False

    def health(self) -> LinkHealth:
        heard = self.clock.now() if self.last_heard_s is None else self.last_heard_s
        return LinkHealth(
            connected=self.connected,
            last_heard_s=heard,
            estopped=self.estopped,
            bus_fault=self.bus_fault,
            faulted_boards=self.faulted_boards,
        )

    def close(self) -> None:
        self.closed = True

    # -- crude physics -------------------------------------------------------

    def half_clamped(self, half: Half) -> bool:
        """The fake's own truth: every joint of ``half`` holds at least the minimum torque."""
        for m in self._robot.bend_modules(half):
            mode, value = self.setpoints.get(
                self._robot.joint_motor(m.name).name, (ControlMode.POSITION, 0.0)
            )
            if mode is not ControlMode.TORQUE or value < self._robot.clamp.min_torque:
                return False
        return True

    def _apply(self, batch: Sequence[MotorCommand]) -> None:
        robot = self._robot
        steep = abs(self.values.get(f"{self.imu_prefix}.pitch", 0.0)) > (
            robot.motion.max_unclamped_slope
        )
        for c in batch:
            motor = robot.motor(c.motor)
            limit = motor.limits.torque
            if c.mode is ControlMode.TORQUE and limit is not None and abs(c.value) > limit.max:
                self.violations.events.append(f"over-torque {c.motor}")
            fn = motor.function
            if fn is MotorFunction.BEND:
                module = robot.module_of(c.motor).name
                sensor = self._joint_sensor[module]
                spring = self._spring_sensor.get(module)
                if c.mode is ControlMode.TORQUE and c.value > 0:
                    contact = robot.clamp.contact_angle(self.diameter_m)
                    self.values[sensor] = contact
                    if spring is not None:
                        self.values[spring] = c.value / robot.clamp.lever_arm
                else:
                    self.values[sensor] = c.value if c.mode is ControlMode.POSITION else 0.0
                    if spring is not None:
                        self.values[spring] = 0.0
            elif fn is MotorFunction.ROTATE:
                if c.mode is ControlMode.PWM and c.value == 0.0:
                    continue  # a brake (every stop's): the halves stay where they are
                clamped = sum(self.half_clamped(h) for h in Half)
                if clamped != 1:
                    self.violations.events.append(f"rotate with {clamped} halves clamped")
                self.values[self.rotation_channel] = c.value
            elif fn is MotorFunction.TILT and self.tilt_channel is not None:
                if c.mode is ControlMode.PWM and c.value == 0.0:
                    continue  # a brake (a reset's stop category): the module stays
                if self.half_clamped(Half.FRONT) and abs(c.value) < robot.clamp.front_clear_angle:
                    self.violations.events.append("front module pushed into the front clamp")
                self.values[self.tilt_channel] = c.value
            elif fn is MotorFunction.DRIVE:
                self.values[f"{c.motor}.velocity"] = c.value
        if steep and not any(self.half_clamped(h) for h in Half) and _touches_clamp(batch, robot):
            self.violations.events.append("both halves unclamped in a steep pipe")
        if self.tilt_channel is not None and self.half_clamped(Half.FRONT):
            tilt = self.values[self.tilt_channel]
            if abs(tilt) < robot.clamp.front_clear_angle - math.radians(0.5):
                self.violations.events.append("front half clamped on the front module")


def _touches_clamp(batch: Sequence[MotorCommand], robot: RobotDescription) -> bool:
    return any(robot.motor(c.motor).function is MotorFunction.BEND for c in batch)
