"""JSON Schema of robot descriptions, for editors and ``pirate-bt schema hardware``."""

from __future__ import annotations

from typing import Any

from pirate_bt.robot.description import RobotDescription

__all__ = ["robot_schema"]


def robot_schema() -> dict[str, Any]:
    """The JSON Schema (draft 2020-12) of ``hardware/*.yaml``."""
    schema = RobotDescription.model_json_schema(mode="validation")
    schema["$schema"] = "https://json-schema.org/draft/2020-12/schema"
    schema["title"] = "pirate_bt robot description"
    return schema
