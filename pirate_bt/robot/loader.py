"""Load and validate robot descriptions with located errors."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from pirate_bt.resources import default_robot_path
from pirate_bt.robot.description import RobotDescription
from pirate_bt.yamlfile import Locator, YamlDocument, load_yaml, validate_document

__all__ = ["load_robot", "robot_from_data", "robot_from_document"]

_FILE_CONTEXT = {"units_required": True, "defer_cross_checks": True}


def robot_from_document(doc: YamlDocument) -> RobotDescription:
    """Validate a loaded YAML document as a robot description.

    Raises:
        ValidationFailed: every problem, each at ``file:line:column``.
    """
    return validate_document(doc, RobotDescription, "a robot description", _FILE_CONTEXT)


def robot_from_data(data: Mapping[str, Any], name: str = "<data>") -> RobotDescription:
    """Validate plain data (as from a YAML file, units required) as a robot description."""
    return robot_from_document(YamlDocument(dict(data), Locator(name)))


def load_robot(path: str | Path | None = None) -> RobotDescription:
    """Load a robot description file; ``None`` loads the bundled 2018 robot.

    Raises:
        ValidationFailed: the file cannot be read or does not validate.

    Example::

        robot = pirate_bt.load_robot()                  # hardware/pirate.yaml
        print(robot.name)                               # PIRATE 2018
        result = pirate_bt.simulate_tree("straight", robot=robot,
                                         params={"distance": "1 m"})
    """
    return robot_from_document(load_yaml(path if path is not None else default_robot_path()))
