"""Motor commands in SI units, and their raw form for the wire.

Above the link, a command is a :class:`MotorCommand`: a motor by name, a control
mode and a value in that mode's SI unit (duty fraction for ``pwm``, N·m for
``torque``, rad for ``position``, m/s for ``velocity``). :class:`CommandCodec`
turns it into a :class:`RawSetpoint` (board, slot, mode, raw integer) with the
description's conversion, and back. Only the link and this module handle
``raw_value``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from pirate_bt.errors import InputError
from pirate_bt.robot.description import ControlMode, RobotDescription

__all__ = ["CommandCodec", "MotorCommand", "RawSetpoint"]


@dataclass(frozen=True, slots=True)
class MotorCommand:
    """Drive one motor in one mode to a value in SI units."""

    motor: str
    mode: ControlMode
    value: float


@dataclass(frozen=True, slots=True)
class RawSetpoint:
    """A setpoint as the wire carries it."""

    board: int
    slot: int
    mode: ControlMode
    raw_value: int


class CommandCodec:
    """Converts commands between SI (:class:`MotorCommand`) and raw (:class:`RawSetpoint`)."""

    def __init__(self, robot: RobotDescription) -> None:
        self.robot = robot
        self._by_slot = {(s.board, s.slot): s.motor for s in robot.setpoint_slots()}

    def to_raw(self, command: MotorCommand) -> RawSetpoint:
        """The raw setpoint for ``command``; values beyond the raw range saturate.

        Raises:
            InputError: unknown motor, a mode the motor does not support, or a value
                that is not a finite number (NaN or infinite: nothing to saturate).
        """
        try:
            motor = self.robot.motor(command.motor)
        except KeyError:
            raise InputError(f"unknown motor {command.motor!r}") from None
        conversion = motor.modes.get(command.mode)
        if conversion is None:
            modes = ", ".join(m.value for m in motor.modes.available())
            raise InputError(f"motor {motor.name!r} has no {command.mode} mode (it has: {modes})")
        value = command.value
        if not math.isfinite(value):
            raise InputError(f"motor {motor.name!r}: {command.mode} value {value} is not finite")
        board = self.robot.board_of(motor.name)
        return RawSetpoint(board.id, motor.slot, command.mode, conversion.to_raw(value))

    def to_si(self, setpoint: RawSetpoint) -> MotorCommand:
        """The SI command a raw setpoint stands for.

        Raises:
            InputError: no motor at that board and slot, or an unsupported mode.
        """
        motor = self._by_slot.get((setpoint.board, setpoint.slot))
        if motor is None:
            raise InputError(f"no motor at board {setpoint.board} slot {setpoint.slot}")
        conversion = motor.modes.get(setpoint.mode)
        if conversion is None:
            raise InputError(f"motor {motor.name!r} has no {setpoint.mode} mode")
        return MotorCommand(motor.name, setpoint.mode, conversion.to_si(setpoint.raw_value))
