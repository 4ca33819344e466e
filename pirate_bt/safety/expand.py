"""Expansion: a high-level command becomes the motor commands it means.

:class:`Expander` turns a :class:`~pirate_bt.safety.commands.Command` into an
:class:`~pirate_bt.safety.checks.Intent` (the motor commands, which halves it
clamps, releases or presses, the sensor channels the decision relies on) or a
:class:`~pirate_bt.safety.checks.Problem` when the command names nothing real.
The :class:`~pirate_bt.safety.supervisor.Supervisor` checks the intent next.
"""

from __future__ import annotations

import contextlib
import math
import numbers
from dataclasses import fields, replace

from pirate_bt.robot.commands import MotorCommand
from pirate_bt.robot.description import (
    ControlMode,
    Half,
    Motor,
    MotorFunction,
    RobotDescription,
    Role,
    SensorKind,
)
from pirate_bt.robot.state import RobotState
from pirate_bt.safety.checks import Intent, Problem, front_tilt_channel
from pirate_bt.safety.commands import (
    Bend,
    Clamp,
    Command,
    Drive,
    MoveFrontClear,
    Raw,
    Rotate,
    Stop,
    Tilt,
    Unclamp,
    member_of,
)
from pirate_bt.safety.verdict import Reason

__all__ = ["Expander", "well_formed"]

# Motor functions whose commands no invariant is about (lights, cameras).
_FREE_FUNCTIONS = frozenset(
    {MotorFunction.LEDS, MotorFunction.CAMERA_TILT, MotorFunction.CAMERA_PAN}
)


_NUMBERS = ("torque_nm", "velocity_mps", "angle_rad", "sign")
_NOT_NUMBERS = "command values must be finite numbers"  # tests pin it
_KINDS = (Clamp, Unclamp, Drive, Bend, Rotate, Tilt, MoveFrontClear, Stop, Raw)


def _number(value: object) -> float | None:
    """``value`` as a finite float, or ``None`` (text, ``None``, a bool, NaN, infinity,
    an integer or fraction too large for a float: ``float(10**400)`` raises)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        return None
    try:
        number = float(value)
    except OverflowError:
        return None
    return number if math.isfinite(number) else None


def well_formed(command: Command) -> Command | Problem:
    """``command`` with its fields as the checks read them, or why it is malformed.

    A command is a frozen dataclass anyone can build with anything in it, and the checks
    compare halves by identity: ``Clamp("rear", 0.7)`` used to pass with nothing sent
    (no bend module is of the half ``"rear"``) and ``Unclamp(None)`` raised. A half
    given as its text (``"rear"``) is read as that half, a control mode likewise, and a
    number must be a real, finite one (not a bool, not text); anything else is refused.

    Every field is read once, here, and a command that is not of its own plain type
    with plain values (a ``float``, a ``str``, a member) is rebuilt as one: the checks
    and the motor commands sent read that copy. A subclass whose field is a property,
    or a ``str`` or ``float`` subclass, could otherwise answer the checks one value and
    the expansion another (a ``Drive`` read finite here and NaN later went out at the
    raw range's 120 mm/s).
    """
    kind = next((k for k in _KINDS if isinstance(command, k)), None)
    if kind is None:
        return command  # no command: the expansion refuses it by name
    values = {f.name: getattr(command, f.name) for f in fields(kind)}
    read = dict(values)
    for name in _NUMBERS:
        if name in values:
            number = _number(values[name])
            if number is None:
                return Problem(Reason.NOT_FINITE, _NOT_NUMBERS)
            values[name] = number
    if "sign" in values:
        values["sign"] = 1 if values["sign"] >= 0 else -1
    if kind is Raw:
        mc = values["command"]
        if not isinstance(mc, MotorCommand):
            return Problem(Reason.UNKNOWN_TARGET, f"not a motor command: {mc!r}"[:200])
        motor, mode, raw_value = mc.motor, mc.mode, mc.value
        if not isinstance(motor, str):
            return Problem(Reason.UNKNOWN_TARGET, f"not a motor command: {mc!r}"[:200])
        value = _number(raw_value)
        if value is None:
            return Problem(Reason.NOT_FINITE, _NOT_NUMBERS)
        member = member_of(ControlMode, mode)
        if member is None:
            return Problem(Reason.MODE_NOT_ALLOWED, f"{mode!r} is not a control mode"[:200])
        plain = MotorCommand(str.__str__(motor), member, value)
        same = plain.motor is motor and plain.mode is mode and plain.value is raw_value
        if type(mc) is not MotorCommand or not same:
            values["command"] = plain
    if "half" in values:
        half = member_of(Half, values["half"])
        if half is None:
            return Problem(
                Reason.UNKNOWN_TARGET, f"not a half: {values['half']!r} (front or rear)"[:200]
            )
        values["half"] = half
    if kind is Bend:
        if not isinstance(values["module"], str):
            return Problem(
                Reason.UNKNOWN_TARGET, f"{values['module']!r} is not a bend module"[:200]
            )
        values["module"] = str.__str__(values["module"])
    if type(command) is kind and all(values[k] is read[k] for k in values):
        return command  # plain already: the command checked is the one it came from
    return kind(**values)


class Expander:
    """Expands commands for one robot description.

    Args:
        robot: The robot the commands are for.
    """

    def __init__(self, robot: RobotDescription) -> None:
        self.robot = robot
        self._tilt_channel = front_tilt_channel(robot)
        self._base_channels = self._safety_channels()

    @property
    def base_channels(self) -> tuple[str, ...]:
        """Channels every motion decision relies on."""
        return self._base_channels

    def expand(self, command: Command, state: RobotState | None) -> Intent | Problem:
        """The intent of ``command`` in ``state``, or the problem that stops it."""
        return self._expand(command, state)

    def _safety_channels(self) -> tuple[str, ...]:
        """Channels every motion decision relies on: joints, springs, IMU pitch."""
        names: list[str] = []
        for module in self.robot.all_bend_modules():
            names.append(self.robot.sensor_of(module.name, SensorKind.ANGLE).name)
            with contextlib.suppress(KeyError):
                names.append(self.robot.sensor_of(module.name, SensorKind.SPRING).name)
        imu = self.robot.imu()
        if imu is not None and "pitch" in imu.axes:
            names.append(f"{imu.name}.pitch")
        return tuple(names)

    def _rotation_channel(self) -> str:
        return self.robot.sensor_of(self.robot.rotational_module().name, SensorKind.ANGLE).name

    def _half_commands(
        self, half: Half, mode: ControlMode, value: float
    ) -> tuple[MotorCommand, ...]:
        return tuple(
            MotorCommand(self.robot.joint_motor(m.name).name, mode, value)
            for m in self.robot.bend_modules(half)
        )

    def _torque_presses(self, half: Half, torque_nm: float) -> frozenset[Half]:
        """``{half}`` when a bend joint torque may push the half's wheels on the wall: any
        torque does, since a joint in torque mode swings until the wall stops it."""
        return frozenset({half}) if torque_nm != 0.0 else frozenset()

    def _position_presses(self, half: Half, angle_rad: float) -> frozenset[Half]:
        """``{half}`` when a bend joint target is at or beyond the smallest wall-contact angle."""
        wall = min(p.angle for p in self.robot.clamp.contact_angles)
        if abs(angle_rad) >= wall - self.robot.safety.angle_tolerance:
            return frozenset({half})
        return frozenset()

    def _reverses(
        self, half: Half, modules: list[str], torque_nm: float, state: RobotState | None
    ) -> frozenset[Half]:
        """``{half}`` when a torque would swing a joint across to the other side.

        A joint bent one way that is driven the other way leaves the wall on its way
        across, so the half lets go before it clamps again: that is a release too.
        Without a reading the worst case is assumed.
        """
        tol = self.robot.safety.angle_tolerance
        pushes = math.copysign(1.0, torque_nm)
        for name in modules:
            angle = state.joint_angle_rad.get(name) if state is not None else None
            if angle is None or (abs(angle) > tol and math.copysign(1.0, angle) != pushes):
                return frozenset({half})
        return frozenset()

    def _front_channels(self, presses: frozenset[Half]) -> tuple[str, ...]:
        """The front tilt channel when the front half may press the wall (checked fresh)."""
        return (self._tilt_channel,) if Half.FRONT in presses and self._tilt_channel else ()

    def _expand(self, command: Command, state: RobotState | None) -> Intent | Problem:
        base = self._base_channels
        formed = well_formed(command)
        if isinstance(formed, Problem):
            return formed
        command = formed
        match command:
            case Clamp(half, torque):
                if torque < self.robot.clamp.min_torque:
                    return Problem(
                        Reason.CLAMP_TORQUE_TOO_LOW,
                        f"clamp torque {torque:g} N·m is below the minimum that holds"
                        f" ({self.robot.clamp.min_torque:g} N·m)",
                    )
                chans = base + (
                    (self._tilt_channel,) if half is Half.FRONT and self._tilt_channel else ()
                )
                modules = [m.name for m in self.robot.bend_modules(half)]
                return Intent(
                    command,
                    self._half_commands(half, ControlMode.TORQUE, torque),
                    clamps=frozenset({half}),
                    releases=self._reverses(half, modules, torque, state),
                    channels=chans,
                )
            case Unclamp(half, angle):
                return Intent(
                    command,
                    self._half_commands(half, ControlMode.POSITION, angle),
                    releases=frozenset({half}),
                    presses=(presses := self._position_presses(half, angle)),
                    channels=base + self._front_channels(presses),
                )
            case Bend(module, angle):
                try:
                    mod = self.robot.module(module)
                    motor = self.robot.joint_motor(module)
                except KeyError:
                    return Problem(Reason.UNKNOWN_TARGET, f"{module!r} is not a bend module")
                if mod.role is not Role.BEND or mod.half is None:
                    return Problem(Reason.UNKNOWN_TARGET, f"{module!r} is not a bend module")
                return Intent(
                    command,
                    (MotorCommand(motor.name, ControlMode.POSITION, angle),),
                    releases=frozenset({mod.half}),
                    presses=(presses := self._position_presses(mod.half, angle)),
                    channels=base + self._front_channels(presses),
                )
            case Rotate(angle):
                return Intent(
                    command,
                    (MotorCommand(self.robot.rotate_motor().name, ControlMode.POSITION, angle),),
                    rotates=True,
                    channels=(*base, self._rotation_channel()),
                )
            case Tilt(angle):
                return self._tilt_intent(command, angle)
            case MoveFrontClear(sign):
                # past the clear angle by the angle tolerance: a position loop settles
                # within its tolerance either side of the target, and the module must
                # end at least clear, not clear give or take the loop's error
                clear = self.robot.clamp.front_clear_angle + self.robot.safety.angle_tolerance
                angle = clear if sign >= 0 else -clear
                return self._tilt_intent(command, angle)
            case Drive(v):
                cmds = tuple(
                    MotorCommand(m.name, ControlMode.VELOCITY, v) for m in self.robot.drive_motors()
                )
                return Intent(command, cmds, drive_mps=v, stop=v == 0.0, channels=base)
            case Raw(mc):
                return self._raw_intent(command, mc, state)
        return Problem(Reason.UNKNOWN_TARGET, f"not a command: {command!r}")  # e.g. Stop()

    def _tilt_motor(self) -> Motor | None:
        try:
            return self.robot.motor_of(self.robot.modules[0].name, MotorFunction.TILT)
        except KeyError:
            return None

    def _tilt_intent(self, command: Command, angle: float) -> Intent | Problem:
        motor = self._tilt_motor()
        if motor is None or self._tilt_channel is None:
            return Problem(Reason.UNKNOWN_TARGET, "this robot has no front tilt motor")
        return Intent(
            command,
            (MotorCommand(motor.name, ControlMode.POSITION, angle),),
            front_tilt_rad=angle,
            channels=(*self._base_channels, self._tilt_channel),
        )

    def _raw_intent(
        self, command: Raw, mc: MotorCommand, state: RobotState | None
    ) -> Intent | Problem:
        try:
            motor = self.robot.motor(mc.motor)
        except KeyError:
            return Problem(Reason.UNKNOWN_TARGET, f"unknown motor {mc.motor!r}")
        if motor.modes.get(mc.mode) is None:
            return Problem(Reason.MODE_NOT_ALLOWED, f"motor {motor.name!r} has no {mc.mode} mode")
        fn = motor.function
        if fn in _FREE_FUNCTIONS:
            return Intent(command, (mc,))
        base = self._base_channels
        allowed = {
            MotorFunction.BEND: (ControlMode.TORQUE, ControlMode.POSITION),
            MotorFunction.DRIVE: (ControlMode.VELOCITY,),
            MotorFunction.ROTATE: (ControlMode.POSITION,),
            MotorFunction.TILT: (ControlMode.POSITION,),
        }[fn]
        if mc.mode not in allowed:
            return Problem(
                Reason.MODE_NOT_ALLOWED,
                f"{fn} motor {motor.name!r} accepts only"
                f" {', '.join(m.value for m in allowed)} through the supervisor",
            )
        if fn is MotorFunction.BEND:
            half = self.robot.module_of(motor.name).half
            assert half is not None
            presses = (
                self._torque_presses(half, mc.value)
                if mc.mode is ControlMode.TORQUE
                else self._position_presses(half, mc.value)
            )
            chans = base + self._front_channels(presses)
            # A joint presses the wall in either sign: a negative torque clamps too, but a
            # torque against the side the joint is on swings it off the wall first.
            if mc.mode is ControlMode.TORQUE and abs(mc.value) >= self.robot.clamp.min_torque:
                module = self.robot.module_of(motor.name).name
                return Intent(
                    command,
                    (mc,),
                    clamps=frozenset({half}),
                    releases=self._reverses(half, [module], mc.value, state),
                    presses=presses,
                    channels=chans,
                )
            return Intent(
                command, (mc,), releases=frozenset({half}), presses=presses, channels=chans
            )
        if fn is MotorFunction.DRIVE:
            return Intent(command, (mc,), drive_mps=mc.value, stop=mc.value == 0.0, channels=base)
        if fn is MotorFunction.ROTATE:
            return Intent(command, (mc,), rotates=True, channels=(*base, self._rotation_channel()))
        intent = self._tilt_intent(command, mc.value)
        return intent if isinstance(intent, Problem) else replace(intent, motor_commands=(mc,))
