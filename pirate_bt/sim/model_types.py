"""The simulator's state and truth types: what ``PipeRobotModel`` is made of.

- :class:`SensorNoise`, :class:`HalfTruth`, :class:`SimTruth`: the public types
  (re-exported by :mod:`pirate_bt.sim.model`).
- ``_Motor``, ``_Half``, ``_Tally``: the model's mutable state per motor, per half,
  and its counters; the shared constants and ``_wrap``.

Add a field here when a physical rule needs new state; the rules themselves live
in :mod:`~pirate_bt.sim.model_joints`, :mod:`~pirate_bt.sim.model_motion`,
:mod:`~pirate_bt.sim.model_readings` and :mod:`~pirate_bt.sim.model_events`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

from pirate_bt.errors import ArgumentTypeError, ArgumentValueError, kind_of, shown
from pirate_bt.pipes import TeeChoice
from pirate_bt.robot.description import ControlMode, Half, MotorFunction

__all__ = ["HalfTruth", "SensorNoise", "SimTruth"]

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
    """On joint angles, the rotation sensor and the IMU's angles (rad)."""
    force_n: float = 0.0
    """On the springs' clamp forces (N)."""
    velocity_mps: float = 0.0
    """On the wheel speeds the encoders read (m/s)."""
    current_a: float = 0.0
    """On the motor currents (A)."""

    def __post_init__(self) -> None:
        """Refuse a deviation that is no finite number of at least 0, naming it (``inf``
        raised *OverflowError* at the first STATE frame, text a *TypeError*, ``nan``
        and a negative one were taken)."""
        for name in ("angle_rad", "force_n", "velocity_mps", "current_a"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise ArgumentTypeError(
                    f"noise: {name}: give a standard deviation (a number), not {kind_of(value)}"
                )
            try:
                good = math.isfinite(value) and value >= 0
            except OverflowError:  # a whole number too large for a float
                good = False
            if not good:
                raise ArgumentValueError(
                    f"noise: {name}: {shown(value)} is not a standard deviation: give a finite"
                    " number of at least 0"
                )

    @classmethod
    def typical(cls) -> SensorNoise:
        """About one raw step of noise on every reading."""
        return cls(angle_rad=0.002, force_n=0.05, velocity_mps=0.0002, current_a=0.005)


_NO_NOISE = SensorNoise()


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
