"""Load and validate robot descriptions with located errors."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from pirate_bt.errors import (
    LocatedError,
    SourceLocation,
    ValidationFailed,
    file_argument,
)
from pirate_bt.resources import default_robot_path
from pirate_bt.robot.description import RobotDescription
from pirate_bt.yamlfile import YamlDocument, data_document, load_yaml
from pirate_bt.yamlvalidate import validate_document

__all__ = ["load_robot", "robot_from_data", "robot_from_document"]

_FILE_CONTEXT = {"units_required": True, "defer_cross_checks": True}


def robot_from_document(doc: YamlDocument) -> RobotDescription:
    """Validate a loaded YAML document as a robot description.

    Raises:
        ValidationFailed: every problem, each at ``file:line:column``.
    """
    return validate_document(doc, RobotDescription, "a robot description", _FILE_CONTEXT)


def robot_from_data(data: Mapping[str, Any], name: str = "<data>") -> RobotDescription:
    """Validate plain data (as from a YAML file, units required) as a robot description.

    Raises:
        ArgumentTypeError: ``data`` is no mapping or ``name`` no text.
        ValidationFailed: every problem, each at ``name:1:1``.
    """
    return robot_from_document(data_document(data, name))


def load_robot(path: str | Path | None = None) -> RobotDescription:
    """Load a robot description file; ``None`` loads the bundled 2018 robot.

    Raises:
        InputError: ``path`` is no file name (:func:`~pirate_bt.errors.file_argument`:
            a number, bytes, empty, a NUL, more than 4096 characters), named ``path``.
        ValidationFailed: the file cannot be read (a name the system refuses too) or
            does not validate.

    Example::

        robot = pirate_bt.load_robot()                  # hardware/pirate.yaml
        print(robot.name)                               # PIRATE 2018
        result = pirate_bt.simulate_tree("straight", robot=robot,
                                         params={"distance": "1 m"})
    """
    given = default_robot_path() if path is None else file_argument(path, "path")
    try:
        document = load_yaml(given)
    except OSError as exc:  # a name the system refuses (a part longer than 255 bytes)
        where = SourceLocation(str(given))
        raise ValidationFailed([LocatedError(f"cannot read: {exc.strerror}", where)]) from None
    return robot_from_document(document)
