"""The state frame's channels and the bulk setpoint frame's slots of a robot, in layout
order (:class:`pirate_bt.robot.description.RobotDescription` builds them and
re-exports these names)."""

from __future__ import annotations

from dataclasses import dataclass

from pirate_bt.robot.parts import Conversion, Motor

__all__ = ["ChannelSpec", "SetpointSlot"]


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
