"""The parts of a robot description that the workability rules read
(:mod:`pirate_bt.robot.fitness`, :mod:`pirate_bt.robot.firmware_fit`)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from pirate_bt.robot.configs import BridgeConfig, ClampConfig, MotionConfig, SafetyConfig
from pirate_bt.robot.parts import Board, Module

__all__ = ["KeyPath", "Workable"]

KeyPath = tuple[str | int, ...]
"""Where a problem lies: the keys and indices from the file's top."""


@dataclass(frozen=True, slots=True)
class Workable:
    """The parts of a robot description these rules read."""

    modules: Sequence[Module]
    boards: Sequence[Board]
    clamp: ClampConfig
    bridge: BridgeConfig
    safety: SafetyConfig
    motion: MotionConfig
