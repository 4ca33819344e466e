"""The robot as data: description, state snapshots and commands (all in SI units)."""

from pirate_bt.robot.commands import CommandCodec, MotorCommand, RawSetpoint
from pirate_bt.robot.description import (
    ControlMode,
    Half,
    LimitPolicy,
    MotorFunction,
    RobotDescription,
    Role,
    SensorKind,
)
from pirate_bt.robot.loader import load_robot, robot_from_data, robot_from_document
from pirate_bt.robot.port import LinkHealth, RobotPort
from pirate_bt.robot.state import Reading, RobotState, StateBuilder

__all__ = [
    "CommandCodec",
    "ControlMode",
    "Half",
    "LimitPolicy",
    "LinkHealth",
    "MotorCommand",
    "MotorFunction",
    "RawSetpoint",
    "Reading",
    "RobotDescription",
    "RobotPort",
    "RobotState",
    "Role",
    "SensorKind",
    "StateBuilder",
    "load_robot",
    "robot_from_data",
    "robot_from_document",
]
