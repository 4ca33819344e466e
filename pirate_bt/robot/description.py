"""The robot as data: pydantic models of ``hardware/*.yaml``.

A robot description lists the modules front to rear, the PICO boards on the
RS485 bus with their motors and sensors, each motor's control modes with its
raw range and raw<->SI conversion, hard limits with a clip-or-refuse policy,
geometry, and the clamp and motion parameters the simulator and the protective
layer use. Adding a sensor, a motor, a board or a whole module is an edit of
this file, not of code.

Higher layers never ask for "board 22": they ask for roles -
:meth:`RobotDescription.bend_modules` of a half, :meth:`RobotDescription.joint_motor`
of a module, :meth:`RobotDescription.rotate_motor` - and the description answers
from the file.

Validation is two steps. pydantic checks the shape and each field's bounds;
:meth:`RobotDescription.cross_check` then checks the rules that span the file
(unique board ids, every referenced module exists, each half has its bend pair,
limits inside raw ranges) and returns each problem with its path, so the loader
can point at ``file:line:column``.
"""

from __future__ import annotations

import hashlib
import itertools
import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from enum import StrEnum
from typing import Annotated, Any, Literal

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    PrivateAttr,
    ValidationInfo,
    field_validator,
    model_validator,
)

from pirate_bt.units import (
    Acceleration,
    Angle,
    AngularVelocity,
    Current,
    Dimensionless,
    Duration,
    Force,
    Length,
    Torque,
    Velocity,
)

__all__ = [
    "Board",
    "BridgeConfig",
    "ChannelSpec",
    "ClampConfig",
    "ControlMode",
    "Conversion",
    "Half",
    "LimitPolicy",
    "Module",
    "MotionConfig",
    "Motor",
    "MotorFunction",
    "RobotDescription",
    "Role",
    "SafetyConfig",
    "Sensor",
    "SensorKind",
    "SetpointSlot",
]

Name = Annotated[
    str,
    Field(pattern=r"^[a-z][a-z0-9_]*$", max_length=40, description="lower_snake_case name"),
]


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, use_attribute_docstrings=True)


class Half(StrEnum):
    """The two halves of the robot, each a "V" of two bend modules."""

    FRONT = "front"
    REAR = "rear"

    @property
    def other(self) -> Half:
        return Half.REAR if self is Half.FRONT else Half.FRONT


class Role(StrEnum):
    """What a module does; higher layers find modules by role, never by board id."""

    FRONT = "front"
    BEND = "bend"
    ROTATIONAL = "rotational"
    REAR = "rear"


class MotorFunction(StrEnum):
    """What a motor moves."""

    BEND = "bend"
    DRIVE = "drive"
    ROTATE = "rotate"
    TILT = "tilt"
    CAMERA_TILT = "camera_tilt"
    CAMERA_PAN = "camera_pan"
    LEDS = "leds"


class ControlMode(StrEnum):
    """How a PICO board drives a motor (the board closes the loop)."""

    PWM = "pwm"
    TORQUE = "torque"
    POSITION = "position"
    VELOCITY = "velocity"


class SensorKind(StrEnum):
    """What a sensor measures; fixes the dimension of its conversion."""

    ANGLE = "angle"
    SPRING = "spring"
    IMU = "imu"


class LimitPolicy(StrEnum):
    """What the protective layer does with a command outside a limit."""

    CLIP = "clip"
    REFUSE = "refuse"


RawRange = Annotated[
    tuple[int, int],
    Field(description="[min, max] raw integer range on the wire (int16)"),
]


def _check_raw_range(raw: tuple[int, int]) -> tuple[int, int]:
    lo, hi = raw
    if not -32768 <= lo < hi <= 32767:
        raise ValueError(f"raw range [{lo}, {hi}] must be increasing and fit in int16")
    return raw


def _check_zero_raw(zero_raw: int, info: ValidationInfo) -> int:
    raw = info.data.get("raw")
    if raw is not None and not raw[0] <= zero_raw <= raw[1]:
        raise ValueError(f"zero_raw {zero_raw} lies outside the raw range [{raw[0]}, {raw[1]}]")
    return zero_raw


class Conversion(_Model):
    """Linear raw<->SI conversion: ``si = (raw - zero_raw) * per_raw``."""

    raw: RawRange
    """[min, max] raw integer range on the wire (int16)"""
    zero_raw: int = Field(0, description="raw value that means zero")
    per_raw: float = Field(description="SI value of one raw step, with its unit")

    _raw_ok = field_validator("raw")(classmethod(lambda cls, v: _check_raw_range(v)))
    _zero_ok = field_validator("zero_raw")(
        classmethod(lambda cls, v, info: _check_zero_raw(v, info))
    )

    @field_validator("per_raw")
    @classmethod
    def _per_raw_ok(cls, value: float) -> float:
        if value == 0 or not math.isfinite(value):
            raise ValueError("per_raw must be a non-zero finite quantity")
        return value

    def to_si(self, raw: int) -> float:
        """The SI value of a raw reading."""
        return (raw - self.zero_raw) * self.per_raw

    def to_raw(self, value_si: float) -> int:
        """The nearest raw value, saturated to the raw range."""
        raw = round(value_si / self.per_raw + self.zero_raw)
        lo, hi = self.raw
        return lo if raw < lo else hi if raw > hi else raw

    @property
    def si_range(self) -> tuple[float, float]:
        a, b = self.to_si(self.raw[0]), self.to_si(self.raw[1])
        return (a, b) if a <= b else (b, a)


class PwmConversion(Conversion):
    """PWM duty: ``per_raw`` is the duty fraction of one raw step (e.g. ``0.392 %``)."""

    per_raw: Dimensionless
    """duty fraction of one raw step, e.g. `0.392 %`"""


class TorqueConversion(Conversion):
    """Torque setpoint: ``per_raw`` in N·m per raw step."""

    per_raw: Torque
    """torque of one raw step, e.g. `1 mN*m`"""


class PositionConversion(Conversion):
    """Position setpoint or angle reading: ``per_raw`` is an angle per raw step."""

    per_raw: Angle
    """angle of one raw step, e.g. `0.0879 deg`"""


class VelocityConversion(Conversion):
    """Wheel velocity: ``per_raw`` in m/s per raw step."""

    per_raw: Velocity
    """speed of one raw step, e.g. `0.1 mm/s`"""


class CurrentConversion(Conversion):
    """Motor current: ``per_raw`` in A per raw step."""

    per_raw: Current
    """current of one raw step, e.g. `4 mA`"""


class ModeTable(_Model):
    """The control modes a motor accepts, each with its raw range and conversion."""

    pwm: PwmConversion | None = None
    """open-loop duty cycle"""
    torque: TorqueConversion | None = None
    """torque setpoint (clamping)"""
    position: PositionConversion | None = None
    """angle setpoint, closed on the board"""
    velocity: VelocityConversion | None = None
    """wheel speed setpoint, closed on the board"""

    def get(self, mode: ControlMode) -> Conversion | None:
        value: Conversion | None = getattr(self, mode.value)
        return value

    def available(self) -> list[ControlMode]:
        return [m for m in ControlMode if self.get(m) is not None]


class _Limit(_Model):
    policy: LimitPolicy = Field(
        LimitPolicy.REFUSE, description="clip the command to the limit, or refuse it"
    )


class AngleRange(_Limit):
    """Allowed joint angle range."""

    min: Angle
    """lower end"""
    max: Angle
    """upper end"""

    @model_validator(mode="after")
    def _order(self) -> AngleRange:
        if self.min >= self.max:
            raise ValueError("angle limit: min must be below max")
        return self


class TorqueMax(_Limit):
    """Largest torque magnitude."""

    max: Torque = Field(gt=0)
    """largest torque magnitude"""


class VelocityMax(_Limit):
    """Largest linear speed (drive motors)."""

    max: Velocity = Field(gt=0)
    """largest speed"""


class AngularVelocityMax(_Limit):
    """Largest joint speed; also the largest rate of change of a position setpoint."""

    max: AngularVelocity = Field(gt=0)
    """largest joint speed"""


class AccelerationMax(_Limit):
    """Largest rate of change of a velocity setpoint."""

    max: Acceleration = Field(gt=0)
    """largest acceleration"""


class MotorLimits(_Model):
    """Hard limits the protective layer enforces, each with its policy."""

    angle: AngleRange | None = None
    """joint angle range"""
    torque: TorqueMax | None = None
    """largest torque"""
    velocity: VelocityMax | None = None
    """largest wheel speed (drive motors)"""
    angular_velocity: AngularVelocityMax | None = None
    """largest joint speed / setpoint rate"""
    acceleration: AccelerationMax | None = None
    """largest change of a velocity setpoint per second"""


class Feedback(_Model):
    """Readings a motor's H-bridge reports back."""

    velocity: VelocityConversion | None = Field(None, description="measured wheel speed")
    current: CurrentConversion | None = Field(None, description="measured motor current")


class Motor(_Model):
    """One motor on a board slot."""

    slot: int = Field(ge=0, le=1, description="motor connector on the PICO board (0 or 1)")
    name: Name
    """unique lower_snake_case name"""
    function: MotorFunction
    """what the motor moves"""
    modes: ModeTable
    """control modes the board offers for this motor"""
    limits: MotorLimits = MotorLimits()
    """hard limits enforced by the protective layer"""
    feedback: Feedback = Feedback()
    """readings the H-bridge reports back"""
    assumption: bool = Field(False, description="true when the values are not public")

    @model_validator(mode="after")
    def _has_mode(self) -> Motor:
        if not self.modes.available():
            raise ValueError(f"motor {self.name!r} declares no control mode")
        return self


class _Sensor(_Model):
    slot: int = Field(ge=0, le=1, description="sensor connector on the PICO board (0 or 1)")
    name: Name
    """unique lower_snake_case name"""
    raw: RawRange
    """[min, max] raw integer range on the wire (int16)"""
    zero_raw: int = 0
    """raw value that means zero"""
    period: Duration = Field(gt=0, description="expected time between fresh readings")
    assumption: bool = False
    """true when the values are not public"""

    _raw_ok = field_validator("raw")(classmethod(lambda cls, v: _check_raw_range(v)))
    _zero_ok = field_validator("zero_raw")(
        classmethod(lambda cls, v, info: _check_zero_raw(v, info))
    )

    def conversion(self) -> Conversion:
        raise NotImplementedError

    @property
    def channels(self) -> tuple[str, ...]:
        return ("value",)

    def channel_names(self) -> list[str]:
        """State-frame channel names: ``name`` or ``name.channel``."""
        chans = self.channels
        return [self.name] if chans == ("value",) else [f"{self.name}.{c}" for c in chans]


class AngleSensor(_Sensor):
    """A joint or module angle encoder."""

    kind: Literal[SensorKind.ANGLE]
    """an angle encoder"""
    per_raw: Angle
    """angle of one raw step, e.g. `0.0879 deg`"""

    def conversion(self) -> Conversion:
        return Conversion(raw=self.raw, zero_raw=self.zero_raw, per_raw=self.per_raw)


class SpringSensor(_Sensor):
    """A spring deflection sensor that reads the wheel's normal force."""

    kind: Literal[SensorKind.SPRING]
    """a spring (normal force) sensor"""
    per_raw: Force
    """force of one raw step, e.g. `50 mN`"""

    def conversion(self) -> Conversion:
        return Conversion(raw=self.raw, zero_raw=self.zero_raw, per_raw=self.per_raw)


class ImuSensor(_Sensor):
    """An inertial unit reporting roll, pitch and yaw of its module."""

    kind: Literal[SensorKind.IMU]
    """an inertial unit"""
    per_raw: Angle
    """angle of one raw step, e.g. `0.0879 deg`"""
    axes: tuple[str, ...] = ("roll", "pitch", "yaw")
    """channel names, one int16 each"""

    @property
    def channels(self) -> tuple[str, ...]:
        return self.axes

    def conversion(self) -> Conversion:
        return Conversion(raw=self.raw, zero_raw=self.zero_raw, per_raw=self.per_raw)


Sensor = Annotated[AngleSensor | SpringSensor | ImuSensor, Field(discriminator="kind")]


class Board(_Model):
    """A PICO board: up to two motors and two sensors, on one module."""

    id: int = Field(ge=1, le=254, description="RS485 address of the board")
    module: Name = Field(description="name of the module the board sits in")
    motors: list[Motor] = Field(default_factory=list, max_length=2)
    """motors on slots 0 and 1"""
    sensors: list[Sensor] = Field(default_factory=list, max_length=2)
    """sensors on slots 0 and 1"""


class Module(_Model):
    """One module of the chain, front to rear."""

    name: Name
    """unique lower_snake_case name"""
    role: Role
    """what the module does"""
    half: Half | None = Field(
        description="the half the module belongs to; null for the rotational module"
    )
    length: Length = Field(gt=0, description="length along the pipe axis")
    wheel_radius: Length | None = Field(None, gt=0)
    """drive wheel radius (modules with wheels)"""
    assumption: bool = False
    """true when the values are not public"""


class ContactPoint(_Model):
    """Joint angle at which the wheels touch the wall, for one pipe diameter."""

    diameter: Length = Field(gt=0)
    """internal pipe diameter"""
    angle: Angle = Field(gt=0)
    """joint angle at wall contact"""


class Band(_Model):
    """An angle band [min, max]."""

    min: Angle
    """lower end"""
    max: Angle
    """upper end"""

    @model_validator(mode="after")
    def _order(self) -> Band:
        if self.min >= self.max:
            raise ValueError("band: min must be below max")
        return self

    def contains(self, angle_rad: float) -> bool:
        return self.min <= angle_rad <= self.max


_HOLD_SLACK = 1e-9


class ClampConfig(_Model):
    """How a half clamps: joint torque presses the wheels against the wall."""

    nominal_band: Band = Field(description="joint angles at which a clamp counts as nominal")
    min_torque: Torque = Field(
        gt=0,
        description="least joint torque that holds a clamp: the one threshold of 'clamped',"
        " read by the simulator (torque) and the protective layer (spring force)",
    )
    lever_arm: Length = Field(gt=0, description="normal force = joint torque / lever arm")
    contact_angles: list[ContactPoint] = Field(
        min_length=2, description="wall-contact joint angle against pipe diameter (interpolated)"
    )
    unclamped_below: Angle = Field(description="joint angle below which a half is unclamped")
    front_clear_angle: Angle = Field(
        description="front tilt angle that moves the front module clear before a front clamp"
    )
    assumption: bool = False
    """true when the values are not public"""

    @property
    def holding_force_n(self) -> float:
        """The wall normal force of one joint pressing with :attr:`min_torque`."""
        return self.min_torque / self.lever_arm

    def holds(self, torque_nm: float) -> bool:
        """Whether a joint pressing the wall with ``torque_nm`` holds its half.

        This is the one meaning of "clamped": the simulator asks it of each joint's
        press torque, the protective layer asks :meth:`holds_force` of each spring
        reading. A relative slack of 1e-9 absorbs float rounding only.
        """
        return abs(torque_nm) >= self.min_torque * (1.0 - _HOLD_SLACK)

    def holds_force(self, force_n: float) -> bool:
        """Whether a wheel's wall normal force ``force_n`` shows a holding joint."""
        return abs(force_n) >= self.holding_force_n * (1.0 - _HOLD_SLACK)

    def contact_angle(self, diameter_m: float) -> float:
        """Wall-contact angle for a pipe diameter, linearly interpolated and held at the ends."""
        pts = self.contact_angles
        if diameter_m <= pts[0].diameter:
            return pts[0].angle
        for a, b in itertools.pairwise(pts):
            if diameter_m <= b.diameter:
                t = (diameter_m - a.diameter) / (b.diameter - a.diameter)
                return a.angle + t * (b.angle - a.angle)
        return pts[-1].angle


class MotionConfig(_Model):
    """Motion and physics parameters shared by the simulator and the protective layer."""

    nominal_speed: Velocity = Field(gt=0)
    """cruise speed of a straight run"""
    friction_coefficient: Dimensionless = Field(gt=0, le=2)
    """wheel-wall friction; traction = friction x normal force"""
    alignment_tolerance: Angle = Field(gt=0, description="bend-plane alignment needed at a bend")
    steer_angle: Angle = Field(gt=0, description="joint angle that counts as steered into a bend")
    max_unclamped_slope: Angle = Field(
        ge=0, description="steepest pipe in which both halves may be unclamped"
    )
    over_torque_time: Duration = Field(gt=0, description="time above torque limit = damage")
    weight: Force = Field(15.0, gt=0, description="robot weight (gravity load on slopes)")
    drive_free_current: Current = Field(0.15, ge=0, description="drive current, wheels free")
    drive_stall_current: Current = Field(1.5, gt=0, description="drive current, wheels blocked")
    position_hold_torque: Torque = Field(
        0.4, gt=0, description="torque a position-mode joint presses with when held by the wall"
    )
    slide_speed: Velocity = Field(0.2, gt=0, description="speed of an unclamped robot sliding")
    assumption: bool = False
    """true when the values are not public"""


class SafetyConfig(_Model):
    """Parameters of the protective layer (``pirate_bt.safety``); every field has a default."""

    stale_after_periods: float = Field(
        10.0, gt=1, description="a reading older than this many sensor periods is stale"
    )
    max_link_silence: Duration = Field(
        0.5, gt=0, description="longest time without a valid frame before the link counts as lost"
    )
    max_refusals: int = Field(
        5, ge=1, description="consecutive refused tree commands that put the robot in safe state"
    )
    rate_window: Duration = Field(
        0.1, gt=0, description="longest time step a rate-of-change limit allows in one command"
    )
    angle_tolerance: Angle = Field(
        0.03, ge=0, description="slack on clamp-contact and front-clear angle comparisons"
    )
    release_force_fraction: Dimensionless = Field(
        0.2, ge=0, le=1, description="below this share of the minimum clamp force a half is free"
    )
    clamp_force_fraction: Dimensionless = Field(
        0.9,
        gt=0,
        le=1,
        description="share of a clamp's commanded force a clamp step waits to read (sensor"
        " slack); whether a half holds is clamp.min_torque alone",
    )


class BridgeConfig(_Model):
    """The PIRATEbay bridge and its serial line."""

    baud: int = Field(115200, ge=1200, le=4_000_000)
    """serial line speed (bit/s)"""
    state_period: Duration = Field(gt=0, description="time between state frames")
    watchdog: Duration = Field(gt=0, description="bridge stops drives when the host is silent")
    reset_time: Duration = Field(ge=0, description="Arduino reset after DTR toggles on open")


@dataclass(frozen=True, slots=True)
class ChannelSpec:
    """One int16 value in the state frame, in layout order."""

    index: int
    board: int
    name: str
    conversion: Conversion
    dimension: str
    period_s: float | None


@dataclass(frozen=True, slots=True)
class SetpointSlot:
    """One motor in the bulk setpoint frame, in layout order."""

    index: int
    board: int
    slot: int
    motor: Motor


class RobotDescription(_Model):
    """A whole robot: modules front to rear, boards, and parameters."""

    schema_version: Literal[1] = 1
    """version of this file format"""
    name: str = Field(min_length=1)
    """the robot's name"""
    description: str = ""
    """free text"""
    assumptions: list[str] = Field(
        default_factory=list, description="values in this file that are not public, and why"
    )
    templates: dict[str, Any] = Field(
        default_factory=dict, description="free space for YAML anchors; ignored"
    )
    modules: list[Module] = Field(min_length=3)
    """modules front to rear"""
    boards: list[Board] = Field(min_length=1)
    """PICO boards on the RS485 bus"""
    clamp: ClampConfig
    motion: MotionConfig
    bridge: BridgeConfig
    safety: SafetyConfig = SafetyConfig()

    _index: _Index = PrivateAttr()

    @model_validator(mode="after")
    def _cross(self, info: ValidationInfo) -> RobotDescription:
        context = info.context if isinstance(info.context, dict) else {}
        problems = self.cross_check()
        if problems and not context.get("defer_cross_checks"):
            raise ValueError("; ".join(msg for _, msg in problems))
        if not problems:
            self._index = _Index.build(self)
        return self

    # -- cross-field rules ------------------------------------------------

    def cross_check(self) -> list[tuple[tuple[str | int, ...], str]]:
        """Rules that span the file, each as ``(path, message)``; empty when valid."""
        out: list[tuple[tuple[str | int, ...], str]] = []
        modules = {m.name: i for i, m in enumerate(self.modules)}
        seen_mod: set[str] = set()
        for i, mod in enumerate(self.modules):
            if mod.name in seen_mod:
                out.append((("modules", i, "name"), f"duplicate module name {mod.name!r}"))
            seen_mod.add(mod.name)
            if mod.role is Role.ROTATIONAL and mod.half is not None:
                out.append((("modules", i, "half"), "the rotational module belongs to no half"))
            if mod.role is not Role.ROTATIONAL and mod.half is None:
                out.append((("modules", i, "half"), f"module {mod.name!r} needs a half"))
        roles = [m.role for m in self.modules]
        if roles[0] is not Role.FRONT:
            out.append((("modules", 0, "role"), "the first module must have role 'front'"))
        if roles[-1] is not Role.REAR:
            out.append(
                (("modules", len(roles) - 1, "role"), "the last module must have role 'rear'")
            )
        rot = [i for i, r in enumerate(roles) if r is Role.ROTATIONAL]
        if len(rot) != 1:
            out.append((("modules",), f"need exactly one rotational module, found {len(rot)}"))
        else:
            for i, mod in enumerate(self.modules):
                want = Half.FRONT if i < rot[0] else Half.REAR if i > rot[0] else None
                if want is not None and mod.half not in (None, want):
                    out.append(
                        (("modules", i, "half"), f"module {mod.name!r} lies in the {want} half")
                    )

        ids: dict[int, int] = {}
        names: dict[str, tuple[str | int, ...]] = {}
        for b, board in enumerate(self.boards):
            if board.id in ids:
                out.append(
                    (
                        ("boards", b, "id"),
                        f"duplicate board id {board.id} (also boards[{ids[board.id]}])",
                    )
                )
            ids.setdefault(board.id, b)
            if board.module not in modules:
                out.append(
                    (("boards", b, "module"), f"board {board.id}: unknown module {board.module!r}")
                )
            for kind, items in (("motors", board.motors), ("sensors", board.sensors)):
                slots: set[int] = set()
                for j, item in enumerate(items):
                    path: tuple[str | int, ...] = ("boards", b, kind, j)
                    if item.slot in slots:
                        out.append(
                            (
                                (*path, "slot"),
                                f"board {board.id}: {kind[:-1]} slot {item.slot} used twice",
                            )
                        )
                    slots.add(item.slot)
                    if item.name in names:
                        out.append(((*path, "name"), f"duplicate name {item.name!r}"))
                    names.setdefault(item.name, path)
            for j, motor in enumerate(board.motors):
                out.extend(_motor_limit_problems(motor, ("boards", b, "motors", j)))

        by_module: dict[str, list[Board]] = {}
        for board in self.boards:
            by_module.setdefault(board.module, []).append(board)

        def has(module: str, function: MotorFunction | None, sensor: SensorKind | None) -> bool:
            bs = by_module.get(module, [])
            if function is not None and not any(
                m.function is function for x in bs for m in x.motors
            ):
                return False
            return sensor is None or any(s.kind is sensor for x in bs for s in x.sensors)

        for half in Half:
            bends = [m for m in self.modules if m.role is Role.BEND and m.half is half]
            if len(bends) < 2 or len(bends) % 2:
                out.append(
                    (
                        ("modules",),
                        f"the {half} half needs its bend pair (an even number >= 2 of bend"
                        f" modules), found {len(bends)}",
                    )
                )
        for i, mod in enumerate(self.modules):
            if mod.role is Role.BEND and not has(mod.name, MotorFunction.BEND, SensorKind.ANGLE):
                out.append(
                    (
                        ("modules", i, "name"),
                        f"bend module {mod.name!r} needs a board with a bend motor"
                        " and an angle sensor",
                    )
                )
            if mod.role is Role.ROTATIONAL and not has(
                mod.name, MotorFunction.ROTATE, SensorKind.ANGLE
            ):
                out.append(
                    (
                        ("modules", i, "name"),
                        f"rotational module {mod.name!r} needs a board with a rotate"
                        " motor and an angle sensor",
                    )
                )
        pts = self.clamp.contact_angles
        for k in range(1, len(pts)):
            if pts[k].diameter <= pts[k - 1].diameter:
                out.append(
                    (
                        ("clamp", "contact_angles", k, "diameter"),
                        "contact_angles must be sorted by increasing diameter",
                    )
                )
        return out

    # -- role-based queries (higher layers use these, never board ids) -----

    def module(self, name: str) -> Module:
        """The module called ``name``.

        Raises:
            KeyError: no such module.
        """
        return self._index.modules[name]

    def bend_modules(self, half: Half) -> list[Module]:
        """The bend modules of a half, front to rear."""
        return [m for m in self.modules if m.role is Role.BEND and m.half is half]

    def all_bend_modules(self) -> list[Module]:
        return [m for m in self.modules if m.role is Role.BEND]

    def rotational_module(self) -> Module:
        return next(m for m in self.modules if m.role is Role.ROTATIONAL)

    def motors(self) -> Iterator[tuple[Board, Motor]]:
        for board in self.boards:
            for motor in board.motors:
                yield board, motor

    def sensors(self) -> Iterator[tuple[Board, AngleSensor | SpringSensor | ImuSensor]]:
        for board in self.boards:
            for sensor in board.sensors:
                yield board, sensor

    def motor(self, name: str) -> Motor:
        """The motor called ``name`` (``KeyError`` if none)."""
        return self._index.motors[name][1]

    def board_of(self, name: str) -> Board:
        """The board that carries motor or sensor ``name``."""
        if name in self._index.motors:
            return self._index.motors[name][0]
        return self._index.sensors[name][0]

    def motor_of(self, module: str, function: MotorFunction) -> Motor:
        """The motor with ``function`` on ``module``'s boards (``KeyError`` if none)."""
        found = self._index.by_function.get((module, function))
        if found is None:
            raise KeyError(f"module {module!r} has no {function} motor")
        return found

    def sensor_of(self, module: str, kind: SensorKind) -> AngleSensor | SpringSensor | ImuSensor:
        """The sensor of ``kind`` on ``module``'s boards (``KeyError`` if none)."""
        found = self._index.by_kind.get((module, kind))
        if found is None:
            raise KeyError(f"module {module!r} has no {kind} sensor")
        return found

    def joint_motor(self, module: str) -> Motor:
        return self.motor_of(module, MotorFunction.BEND)

    def rotate_motor(self) -> Motor:
        return self.motor_of(self.rotational_module().name, MotorFunction.ROTATE)

    def drive_motors(self) -> list[Motor]:
        return [m for _, m in self.motors() if m.function is MotorFunction.DRIVE]

    def imu(self) -> ImuSensor | None:
        for _, s in self.sensors():
            if isinstance(s, ImuSensor):
                return s
        return None

    def module_of(self, name: str) -> Module:
        """The module that carries motor or sensor ``name``."""
        return self.module(self.board_of(name).module)

    # -- wire layout --------------------------------------------------------

    def state_channels(self) -> list[ChannelSpec]:
        """The state frame's int16 channels in wire order (boards by id, sensors, feedback)."""
        return list(self._index.channels)

    def setpoint_slots(self) -> list[SetpointSlot]:
        """The bulk setpoint frame's motors in wire order (boards by id, then slot)."""
        return list(self._index.setpoints)

    def board_ids(self) -> list[int]:
        return sorted(b.id for b in self.boards)

    def layout_digest(self) -> int:
        """A 32-bit digest of the wire layout; both ends compare it at hello time."""
        text = ";".join(f"{c.board}:{c.name}" for c in self._index.channels)
        text += "|" + ";".join(f"{s.board}:{s.slot}" for s in self._index.setpoints)
        return int.from_bytes(hashlib.sha256(text.encode()).digest()[:4], "big")

    def digest(self) -> str:
        """SHA-256 of the whole description, for traces and reports."""
        return hashlib.sha256(self.model_dump_json().encode()).hexdigest()


def _motor_limit_problems(
    motor: Motor, path: tuple[str | int, ...]
) -> list[tuple[tuple[str | int, ...], str]]:
    out: list[tuple[tuple[str | int, ...], str]] = []
    lim = motor.limits

    def inside(limit_value: float, mode: ControlMode, what: str, key: str) -> None:
        conv = motor.modes.get(mode)
        if conv is None:
            return
        lo, hi = conv.si_range
        if not lo - 1e-12 <= limit_value <= hi + 1e-12:
            out.append(
                (
                    (*path, "limits", key),
                    f"motor {motor.name!r}: {what} limit {limit_value:g} lies outside the"
                    f" {mode} mode's raw range ({lo:g} .. {hi:g} in SI)",
                )
            )

    if lim.angle is not None:
        inside(lim.angle.min, ControlMode.POSITION, "angle", "angle")
        inside(lim.angle.max, ControlMode.POSITION, "angle", "angle")
    if lim.torque is not None:
        inside(lim.torque.max, ControlMode.TORQUE, "torque", "torque")
    if lim.velocity is not None:
        inside(lim.velocity.max, ControlMode.VELOCITY, "velocity", "velocity")
    if motor.function is MotorFunction.DRIVE and motor.modes.velocity is None:
        out.append(((*path, "modes"), f"drive motor {motor.name!r} needs a velocity mode"))
    if motor.function in (MotorFunction.BEND, MotorFunction.ROTATE):
        if motor.modes.position is None:
            out.append(((*path, "modes"), f"joint motor {motor.name!r} needs a position mode"))
        if lim.angle is None:
            out.append(((*path, "limits"), f"joint motor {motor.name!r} needs an angle limit"))
    return out


@dataclass
class _Index:
    modules: dict[str, Module]
    motors: dict[str, tuple[Board, Motor]]
    sensors: dict[str, tuple[Board, AngleSensor | SpringSensor | ImuSensor]]
    by_function: dict[tuple[str, MotorFunction], Motor]
    by_kind: dict[tuple[str, SensorKind], AngleSensor | SpringSensor | ImuSensor]
    channels: Sequence[ChannelSpec]
    setpoints: Sequence[SetpointSlot]

    @classmethod
    def build(cls, desc: RobotDescription) -> _Index:
        motors: dict[str, tuple[Board, Motor]] = {}
        sensors: dict[str, tuple[Board, AngleSensor | SpringSensor | ImuSensor]] = {}
        by_function: dict[tuple[str, MotorFunction], Motor] = {}
        by_kind: dict[tuple[str, SensorKind], AngleSensor | SpringSensor | ImuSensor] = {}
        channels: list[ChannelSpec] = []
        setpoints: list[SetpointSlot] = []
        for board in sorted(desc.boards, key=lambda b: b.id):
            for sensor in sorted(board.sensors, key=lambda s: s.slot):
                sensors[sensor.name] = (board, sensor)
                by_kind.setdefault((board.module, sensor.kind), sensor)
                dim = "force" if sensor.kind is SensorKind.SPRING else "angle"
                for name in sensor.channel_names():
                    channels.append(
                        ChannelSpec(
                            len(channels), board.id, name, sensor.conversion(), dim, sensor.period
                        )
                    )
            for motor in sorted(board.motors, key=lambda m: m.slot):
                motors[motor.name] = (board, motor)
                by_function.setdefault((board.module, motor.function), motor)
                setpoints.append(SetpointSlot(len(setpoints), board.id, motor.slot, motor))
                for key, dim in (("velocity", "velocity"), ("current", "current")):
                    conv = getattr(motor.feedback, key)
                    if conv is not None:
                        channels.append(
                            ChannelSpec(
                                len(channels),
                                board.id,
                                f"{motor.name}.{key}",
                                conv,
                                dim,
                                desc.bridge.state_period,
                            )
                        )
        return cls(
            modules={m.name: m for m in desc.modules},
            motors=motors,
            sensors=sensors,
            by_function=by_function,
            by_kind=by_kind,
            channels=tuple(channels),
            setpoints=tuple(setpoints),
        )
