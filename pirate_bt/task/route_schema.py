"""The JSON Schema of a route file (``pirate-bt schema route``), apart from the parser
in :mod:`pirate_bt.task.route`, which re-exports it."""

from __future__ import annotations

from typing import Any

__all__ = ["route_schema"]


def route_schema() -> dict[str, Any]:
    """A JSON Schema for route files (``pirate-bt schema route``).

    Routes are text, not YAML, so the schema describes one line: editors can
    use its pattern, people its description.
    """
    return {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "title": "pirate_bt route (one line of a .route file)",
        "description": (
            "A route is plain text, one command per line; '#' starts a comment. Commands: "
            "network NAME | forward DISTANCE [slowly] | forward to the end | "
            "inspect DISTANCE [slowly] | back DISTANCE | at the bend turn [up|down|left|right] | "
            "at the T-joint go left|right|up|down|straight | go to SEGMENT | pause DURATION | "
            "return to start. See docs/routes.md."
        ),
        "type": "string",
        "pattern": (r"^\s*(#.*|(network|forward|inspect|back|at|go|pause|wait|return)\b.*|)$"),
        "examples": [
            "forward 2.5 m",
            "at the bend turn up",
            "at the T-joint go left",
            "inspect 1 m slowly",
            "return to start",
        ],
    }
