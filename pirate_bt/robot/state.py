"""Immutable robot state snapshots in SI units, built from raw state-frame values.

The link hands up one raw int16 per state channel (see
:meth:`~pirate_bt.robot.description.RobotDescription.state_channels`), or ``None``
where the bridge flagged a reading as not fresh. :class:`StateBuilder` turns that
into a :class:`RobotState`: every channel as a :class:`Reading` with the time it
was last fresh, plus role-based views (joint angles by bend module, clamp forces,
rotation, IMU, drive speeds, motor currents, camera and front tilt).

A snapshot never changes after it is built, so the tree, the supervisor and the
trace can all hold the same one without copying or locking.
"""

from __future__ import annotations

import contextlib
import itertools
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from operator import attrgetter, itemgetter
from types import MappingProxyType
from typing import Any

from pirate_bt.errors import ArgumentTypeError, ArgumentValueError, kind_of, shown
from pirate_bt.robot.description import (
    MotorFunction,
    RobotDescription,
    Role,
    SensorKind,
)

__all__ = [
    "WHEEL_AGREEMENT_FRACTION",
    "WHEEL_AGREEMENT_MPS",
    "Reading",
    "RobotState",
    "StateBuilder",
    "wheel_fresh_window_s",
]

_EMPTY: Mapping[str, float] = MappingProxyType({})
_value = attrgetter("value")


def _optional_value(reading: Reading | None) -> float | None:
    return None if reading is None else reading.value


def _fetcher(channels: list[str]) -> Callable[[Mapping[str, Reading]], tuple[Reading, ...]]:
    """A C-level function: readings -> the readings of ``channels`` as a tuple."""
    get = itemgetter(*channels)
    if len(channels) == 1:
        return lambda readings: (get(readings),)
    return get


@dataclass(frozen=True, slots=True)
class Reading:
    """One value in SI units and the clock time at which it was last fresh."""

    value: float
    stamp_s: float


_new_reading = object.__new__
_set_value = Reading.__dict__["value"].__set__  # the slots' own setters (StateBuilder.build)
_set_stamp = Reading.__dict__["stamp_s"].__set__


@dataclass(frozen=True)
class RobotState:
    """What the robot reported, in SI units; immutable.

    Attributes:
        stamp_s: Clock time at which the state frame arrived.
        readings: Every channel by name (``bend_1_angle``, ``imu.roll``,
            ``bend_1_drive.current``) with its value and freshness stamp.
        joint_angle_rad: Bend joint angle by bend module name.
        clamp_force_n: Spring (normal) force by bend module name.
        rotation_rad: Angle between the halves, if the rotation sensor has reported.
        imu_rad: IMU axes (``roll``, ``pitch``, ``yaw``) in radians.
        drive_velocity_mps: Measured wheel speed by drive motor name.
        motor_current_a: Measured current by motor name.
        camera_tilt_rad: Camera tilt, if reported.
        camera_pan_rad: Camera pan, if reported.
        front_tilt_rad: Front module tilt, if reported.
        row: The views flattened once by the :class:`StateBuilder` that made the
            snapshot, for readers that take every value each tick (the trace): the
            view names in order, ``None`` ending each of the five mappings (one tuple
            object shared by the builder's snapshots while the same channels report),
            and the values in the same order followed by ``rotation_rad``,
            ``camera_tilt_rad``, ``camera_pan_rad`` and ``front_tilt_rad``. ``None`` on
            a snapshot made by hand or by :func:`dataclasses.replace`.
    """

    stamp_s: float
    readings: Mapping[str, Reading]
    joint_angle_rad: Mapping[str, float] = field(default_factory=lambda: _EMPTY)
    clamp_force_n: Mapping[str, float] = field(default_factory=lambda: _EMPTY)
    rotation_rad: float | None = None
    imu_rad: Mapping[str, float] = field(default_factory=lambda: _EMPTY)
    drive_velocity_mps: Mapping[str, float] = field(default_factory=lambda: _EMPTY)
    motor_current_a: Mapping[str, float] = field(default_factory=lambda: _EMPTY)
    camera_tilt_rad: float | None = None
    camera_pan_rad: float | None = None
    front_tilt_rad: float | None = None
    row: tuple[tuple[str | None, ...], tuple[Any, ...]] | None = field(
        default=None, init=False, repr=False, compare=False
    )

    def value(self, name: str) -> float:
        """The value of channel ``name`` (``KeyError`` if it never reported)."""
        return self.readings[name].value

    def age_s(self, name: str, now_s: float) -> float:
        """Seconds since channel ``name`` was last fresh; ``inf`` if never."""
        reading = self.readings.get(name)
        return math.inf if reading is None else now_s - reading.stamp_s

    def oldest_stamp(self, names: Sequence[str]) -> float:
        """The oldest freshness stamp among ``names`` (``-inf`` if any never reported)."""
        stamps = [self.readings[n].stamp_s if n in self.readings else -math.inf for n in names]
        return min(stamps, default=self.stamp_s)

    def mean_drive_velocity_mps(self, fresh_since_s: float | None = None) -> float:
        """Mean measured wheel speed over the drive motors (0 when none reported).

        With ``fresh_since_s`` (odometry's use), two rules keep a bad wheel sensor out:

        - only the wheels whose speed was fresh at or after that clock time count (0
          when none was): a speed sensor that dropped out keeps its last value, which
          odometry must not go on counting. Odometry passes the oldest time a reading
          may be from and still be fresh: ``stamp_s`` less :func:`wheel_fresh_window_s`.
        - of three or more fresh wheels, one that disagrees with the others' median by
          more than :data:`WHEEL_AGREEMENT_MPS` (or :data:`WHEEL_AGREEMENT_FRACTION` of
          the median, if more) is left out, when the wheels that agree are a majority:
          every drive motor is commanded the same speed, so a sensor stuck at a value it
          keeps reporting fresh, or a stalled wheel, is the odd one out. With no
          majority (two wheels, or two groups of equal size) every fresh wheel counts.
        """
        speeds = self.drive_velocity_mps
        values = list(speeds.values())
        if fresh_since_s is not None:
            readings = self.readings
            fresh = [
                v
                for motor, v in speeds.items()
                if (r := readings.get(f"{motor}.velocity")) is None or r.stamp_s >= fresh_since_s
            ]
            if len(fresh) != len(values):
                values = fresh
            if len(values) >= 3 and max(values) - min(values) > WHEEL_AGREEMENT_MPS:
                values = _agreeing(values)
        return sum(values) / len(values) if values else 0.0


WHEEL_AGREEMENT_MPS = 0.01
"""How far (m/s) a wheel's speed may be from the other wheels' median and still count
for odometry (:meth:`RobotState.mean_drive_velocity_mps`)."""

WHEEL_AGREEMENT_FRACTION = 0.25
"""The same, as a fraction of the median's magnitude, where that is larger."""


def _agreeing(values: list[float]) -> list[float]:
    """The speeds within the agreement band of their median, if they are a majority."""
    ordered = sorted(values)
    n = len(ordered)
    half = n // 2
    median = ordered[half] if n % 2 else (ordered[half - 1] + ordered[half]) / 2
    band = max(WHEEL_AGREEMENT_MPS, WHEEL_AGREEMENT_FRACTION * abs(median))
    kept = [v for v in values if abs(v - median) <= band]
    return kept if 2 * len(kept) > n else values


def wheel_fresh_window_s(robot: RobotDescription) -> float:
    """How old a wheel speed may be and still count for odometry:
    ``safety.stale_after_periods`` of the slowest wheel channel's period (the
    supervisor's own freshness rule for its channels)."""
    periods = robot.channel_periods_s()
    default = robot.bridge.state_period
    slowest = max(
        (periods.get(f"{m.name}.velocity", default) for m in robot.drive_motors()),
        default=default,
    )
    return robot.safety.stale_after_periods * slowest


class StateBuilder:
    """Turns raw state-frame values into :class:`RobotState` snapshots.

    Args:
        robot: The robot description whose state layout the frames follow.
    """

    def __init__(self, robot: RobotDescription) -> None:
        if not isinstance(robot, RobotDescription):
            raise ArgumentTypeError(
                f"robot: give a RobotDescription (pirate_bt.robot.load_robot), not {kind_of(robot)}"
            )
        self.robot = robot
        self._channels = robot.state_channels()
        self._scales = [
            (c.name, c.conversion.zero_raw, c.conversion.per_raw) for c in self._channels
        ]
        self._joint: dict[str, str] = {}
        self._spring: dict[str, str] = {}
        for module in robot.all_bend_modules():
            self._joint[module.name] = robot.sensor_of(module.name, SensorKind.ANGLE).name
            with contextlib.suppress(KeyError):
                self._spring[module.name] = robot.sensor_of(module.name, SensorKind.SPRING).name
        rot = robot.rotational_module().name
        self._rotation = robot.sensor_of(rot, SensorKind.ANGLE).name
        imu = robot.imu()
        self._imu = {axis: f"{imu.name}.{axis}" for axis in imu.axes} if imu else {}
        self._velocity = {
            m.name: f"{m.name}.velocity" for m in robot.drive_motors() if m.feedback.velocity
        }
        self._current = {
            m.name: f"{m.name}.current" for _, m in robot.motors() if m.feedback.current
        }
        self._by_function: dict[MotorFunction, str] = {}
        for board, motor in robot.motors():
            if motor.function in (
                MotorFunction.CAMERA_TILT,
                MotorFunction.CAMERA_PAN,
                MotorFunction.TILT,
            ):
                module = robot.module(board.module)
                try:
                    sensor = robot.sensor_of(module.name, SensorKind.ANGLE)
                except KeyError:
                    continue
                # A board with a motor and an angle sensor on the same slot reads that motor.
                for s in board.sensors:
                    if s.slot == motor.slot and s.kind is SensorKind.ANGLE:
                        sensor = s
                if module.role is Role.FRONT:
                    self._by_function[motor.function] = sensor.name
        # The five views flattened (see RobotState.row): one C call fetches their
        # channels' readings, in order; where each view ends among them; the names
        # with a None ending each view; the four single values' channels.
        tables = (self._joint, self._spring, self._imu, self._velocity, self._current)
        channels = [ch for table in tables for ch in table.values()]
        self._fetch: Callable[[Mapping[str, Reading]], tuple[Reading, ...]] = (
            (lambda _readings: ()) if not channels else _fetcher(channels)
        )
        self._view_keys = tuple(tuple(table) for table in tables)
        self._view_ends = tuple(itertools.accumulate(len(table) for table in tables))
        self._layout: tuple[str | None, ...] = tuple(
            name for table in tables for name in (*table, None)
        )
        # A channel that no view has gets a name no reading has: None as its value.
        self._optional = tuple(
            name if name is not None else "\0"
            for name in (
                self._rotation,
                self._by_function.get(MotorFunction.CAMERA_TILT),
                self._by_function.get(MotorFunction.CAMERA_PAN),
                self._by_function.get(MotorFunction.TILT),
            )
        )

    @property
    def channel_names(self) -> list[str]:
        return [c.name for c in self._channels]

    def build(
        self,
        raw: Sequence[int | None],
        stamp_s: float,
        previous: RobotState | None = None,
    ) -> RobotState:
        """Build a snapshot from one frame's raw values.

        Args:
            raw: One value per state channel, in layout order; ``None`` where the
                bridge flagged the reading as not fresh (the previous reading is
                kept with its old stamp, so freshness checks see its age).
            stamp_s: Clock time at which the frame arrived.
            previous: The snapshot before this one, if any.

        Raises:
            ValueError: ``raw`` does not have one value per channel.
        """
        if len(raw) != len(self._channels):
            raise ValueError(f"expected {len(self._channels)} raw values, got {len(raw)}")
        readings: dict[str, Reading] = {}
        old = previous.readings if previous is not None else {}
        # Runs for every STATE frame: the conversion (RawConversion.to_si) inlined, and
        # each Reading made through its slots (a frozen dataclass's __init__ sets each
        # field through object.__setattr__: a third of a snapshot's cost)
        new, set_value, set_stamp = _new_reading, _set_value, _set_stamp
        for (name, zero, per), value in zip(self._scales, raw, strict=True):
            if value is None:
                if name in old:
                    readings[name] = old[name]
            else:
                reading = new(Reading)
                set_value(reading, (value - zero) * per)
                set_stamp(reading, stamp_s)
                readings[name] = reading
        return self._snapshot(readings, stamp_s)

    def from_readings(self, readings: Mapping[str, Reading], stamp_s: float) -> RobotState:
        """Build a snapshot from SI readings by channel name (simulators and tests)."""
        return self._snapshot(dict(readings), stamp_s)

    def _snapshot(self, readings: dict[str, Reading], stamp_s: float) -> RobotState:
        """A snapshot over ``readings``, a dict this builder owns from now on."""
        try:
            # Runs for every STATE frame. Every view's channel has reported (the common
            # case): their values fetched in C, the views cut from one tuple, and the
            # row the trace reads made on the way.
            values = tuple(map(_value, self._fetch(readings)))
        except KeyError:
            return self._partial(readings, stamp_s)
        (jk, fk, ik, dk, ck), (j, f, i, d, c) = self._view_keys, self._view_ends
        rotation, camera_tilt, camera_pan, front_tilt = optional = tuple(
            map(_optional_value, map(readings.get, self._optional))
        )
        state = RobotState(
            stamp_s,
            MappingProxyType(readings),
            MappingProxyType(dict(zip(jk, values[:j]))),  # noqa: B905 (lengths by construction)
            MappingProxyType(dict(zip(fk, values[j:f]))),  # noqa: B905
            rotation,
            MappingProxyType(dict(zip(ik, values[f:i]))),  # noqa: B905
            MappingProxyType(dict(zip(dk, values[i:d]))),  # noqa: B905
            MappingProxyType(dict(zip(ck, values[d:c]))),  # noqa: B905
            camera_tilt,
            camera_pan,
            front_tilt,
        )
        object.__setattr__(state, "row", (self._layout, values + optional))
        return state

    def _partial(self, readings: dict[str, Reading], stamp_s: float) -> RobotState:
        """A snapshot where some view's channel has not reported (no :attr:`~RobotState.row`)."""

        def pick(table: Mapping[str, str]) -> Mapping[str, float]:
            return MappingProxyType(
                {key: readings[ch].value for key, ch in table.items() if ch in readings}
            )

        def one(name: str | None) -> float | None:
            return readings[name].value if name is not None and name in readings else None

        return RobotState(
            stamp_s=stamp_s,
            readings=MappingProxyType(readings),
            joint_angle_rad=pick(self._joint),
            clamp_force_n=pick(self._spring),
            rotation_rad=one(self._rotation),
            imu_rad=pick(self._imu),
            drive_velocity_mps=pick(self._velocity),
            motor_current_a=pick(self._current),
            camera_tilt_rad=one(self._by_function.get(MotorFunction.CAMERA_TILT)),
            camera_pan_rad=one(self._by_function.get(MotorFunction.CAMERA_PAN)),
            front_tilt_rad=one(self._by_function.get(MotorFunction.TILT)),
        )

    def encode(self, values: Mapping[str, float]) -> list[int | None]:
        """SI values by channel name -> raw values in layout order (``None`` if absent).

        This is the inverse of :meth:`build`, for the simulated bridge and tests. A
        value beyond a channel's raw range saturates.

        Raises:
            ArgumentTypeError: ``values`` is no mapping, or a value no number.
            ArgumentValueError: a value is not finite (nothing to saturate), named
                by its channel (it was ``cannot convert float NaN to integer``).
        """
        try:
            return [
                spec.conversion.to_raw(values[spec.name]) if spec.name in values else None
                for spec in self._channels
            ]
        except (TypeError, ValueError, OverflowError):
            self._refuse(values)
            raise

    def _refuse(self, values: object) -> None:
        """Raise the one-line error for what :meth:`encode` could not encode."""
        if not isinstance(values, Mapping):
            raise ArgumentTypeError(
                f"values: give a mapping of channel names to SI values, not {kind_of(values)}"
            ) from None
        for spec in self._channels:
            value = values.get(spec.name)
            if value is None and spec.name not in values:
                continue
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise ArgumentTypeError(
                    f"values: {spec.name}: give a number in SI units, not {kind_of(value)}"
                ) from None
            try:
                finite = math.isfinite(value)
            except OverflowError:
                finite = False
            if not finite:
                raise ArgumentValueError(
                    f"values: {spec.name}: {shown(value)} is not a finite number"
                ) from None
