"""Parts of a robot description: modules, boards, motors, sensors, conversions, limits.

The pydantic models of the pieces a ``hardware/*.yaml`` file lists, and the
enums that name roles, halves, motor functions, control modes and sensor kinds.
:class:`~pirate_bt.robot.description.RobotDescription` puts them together.
"""

from __future__ import annotations

import math
import unicodedata
from enum import StrEnum
from typing import Annotated, Literal

from pydantic import (
    AfterValidator,
    BaseModel,
    ConfigDict,
    Field,
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
    Flag,
    Force,
    Length,
    Torque,
    Velocity,
    WholeNumber,
)

__all__ = [
    "IMU_AXES",
    "AccelerationMax",
    "AngleRange",
    "AngleSensor",
    "AngularVelocityMax",
    "Board",
    "ControlMode",
    "Conversion",
    "CurrentConversion",
    "Feedback",
    "Half",
    "ImuSensor",
    "LimitPolicy",
    "ModeTable",
    "Module",
    "Motor",
    "MotorFunction",
    "MotorLimits",
    "Name",
    "PositionConversion",
    "PwmConversion",
    "RawRange",
    "Role",
    "Sensor",
    "SensorKind",
    "SpringSensor",
    "Title",
    "TorqueConversion",
    "TorqueMax",
    "VelocityConversion",
    "VelocityMax",
]

Name = Annotated[
    str,
    Field(pattern=r"^[a-z][a-z0-9_]*$", max_length=40, description="lower_snake_case name"),
]


def _shown_as_written(name: str) -> str:
    """A robot's or a network's ``name`` that a terminal shows as it is: no control
    character (a newline, an ESC that recoloured or cleared the terminal when
    ``pirate-bt robot`` printed the name), no invisible or text-direction one."""
    for c in name:
        category = unicodedata.category(c)
        if category in ("Cc", "Cf", "Cs"):
            what = "a control character" if category != "Cf" else "an invisible character"
            label = unicodedata.name(c, "") or repr(c)[1:-1]
            raise ValueError(f"name: must not contain U+{ord(c):04X} {label} ({what})")
    return name


Title = Annotated[str, Field(min_length=1), AfterValidator(_shown_as_written)]
"""A robot's or a network's ``name``: text a terminal and a report show as written."""


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
    tuple[WholeNumber, WholeNumber],
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
    zero_raw: WholeNumber = Field(0, description="raw value that means zero")
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
        """The nearest raw value, saturated to the raw range (a value so large that its
        raw value overflows a float saturates too: it raised ``OverflowError``)."""
        scaled = value_si / self.per_raw + self.zero_raw
        if not math.isfinite(value_si):
            return round(scaled)  # OverflowError or ValueError: the callers name the value
        lo, hi = self.raw
        return hi if scaled >= hi else lo if scaled <= lo else round(scaled)

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

    slot: WholeNumber = Field(ge=0, le=1, description="motor connector on the PICO board (0 or 1)")
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
    assumption: Flag = Field(False, description="true when the values are not public")

    @model_validator(mode="after")
    def _has_mode(self) -> Motor:
        if not self.modes.available():
            raise ValueError(f"motor {self.name!r} declares no control mode")
        return self


class _Sensor(_Model):
    slot: WholeNumber = Field(ge=0, le=1, description="sensor connector on the PICO board (0 or 1)")
    name: Name
    """unique lower_snake_case name"""
    raw: RawRange
    """[min, max] raw integer range on the wire (int16)"""
    zero_raw: WholeNumber = 0
    """raw value that means zero"""
    period: Duration = Field(gt=0, description="expected time between fresh readings")
    assumption: Flag = False
    """true when the values are not public"""

    _raw_ok = field_validator("raw")(classmethod(lambda cls, v: _check_raw_range(v)))
    _zero_ok = field_validator("zero_raw")(
        classmethod(lambda cls, v, info: _check_zero_raw(v, info))
    )
    # each kind declares its per_raw; checked here, at the sensor's own key (checked
    # only when the description was built, it was reported at the file's first key)
    _per_raw_ok = field_validator("per_raw", check_fields=False)(
        classmethod(lambda cls, v: Conversion._per_raw_ok(v))
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


IMU_AXES: tuple[str, ...] = ("roll", "pitch", "yaw")
"""The axes an IMU may report, as the firmware names them."""


class ImuSensor(_Sensor):
    """An inertial unit reporting roll, pitch and yaw of its module."""

    kind: Literal[SensorKind.IMU]
    """an inertial unit"""
    per_raw: Angle
    """angle of one raw step, e.g. `0.0879 deg`"""
    axes: tuple[str, ...] = ("roll", "pitch", "yaw")
    """channel names, one int16 each"""

    @field_validator("axes")
    @classmethod
    def _axes_ok(cls, axes: tuple[str, ...]) -> tuple[str, ...]:
        # the PICO firmware reads roll, pitch and yaw only (PB_SRC_IMU_*), and the
        # host takes the IMU's roll and pitch by these names
        for axis in axes:
            if axis not in IMU_AXES:
                raise ValueError(f"IMU axis {axis!r} is not one of {', '.join(IMU_AXES)}")
        if len(set(axes)) != len(axes):
            raise ValueError("an IMU axis is listed twice: each is one channel of its own")
        if not axes:
            raise ValueError(f"an IMU needs at least one axis ({', '.join(IMU_AXES)})")
        return axes

    @property
    def channels(self) -> tuple[str, ...]:
        return self.axes

    def conversion(self) -> Conversion:
        return Conversion(raw=self.raw, zero_raw=self.zero_raw, per_raw=self.per_raw)


Sensor = Annotated[AngleSensor | SpringSensor | ImuSensor, Field(discriminator="kind")]


class Board(_Model):
    """A PICO board: up to two motors and two sensors, on one module."""

    id: WholeNumber = Field(ge=1, le=254, description="RS485 address of the board")
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
    assumption: Flag = False
    """true when the values are not public"""
