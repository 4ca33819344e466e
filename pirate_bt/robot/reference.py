"""Generate the robot description reference page from the models themselves.

``docs/reference/robot-description.md`` is this module's output; a test checks
that the committed page equals it, so the manual and the schema cannot drift.
Regenerate with ``python -m pirate_bt.robot.reference > docs/reference/robot-description.md``.
"""

from __future__ import annotations

import sys
from typing import Any

from pirate_bt.robot.schema import robot_schema

__all__ = ["render_reference"]

_INTRO = """# Robot description reference

A robot description (`hardware/*.yaml`) tells `pirate_bt` everything about one
robot: its modules front to rear, the PICO boards with their motors and sensors,
raw ranges and conversions, limits, geometry and the parameters of the
simulator and protective layer. Check a file with `pirate-bt validate FILE`;
editors can use the JSON Schema from `pirate-bt schema hardware`.

Quantities carry their units (`63 mm`, `0.8 N*m`, `90 deg/s`, `10 ms`); a bare
number is refused except `0`. YAML anchors (`&name`, `*name`, `<<: *name`) may
be kept under `templates`. Unknown keys are errors.

This page is generated from the models (`python -m pirate_bt.robot.reference`);
a test fails when it is out of date.
"""


def _type(prop: dict[str, Any]) -> str:
    if "$ref" in prop:
        name = prop["$ref"].rsplit("/", 1)[-1]
        return f"[{name}](#{name.lower()})"
    options = prop.get("anyOf") or prop.get("oneOf")
    if options:
        if any("with its unit" in p.get("description", "") for p in options):
            return "quantity"
        return " or ".join(dict.fromkeys(_type(p) for p in options))
    if "enum" in prop:
        return " \\| ".join(f"`{v}`" for v in prop["enum"])
    if "const" in prop:
        return f"`{prop['const']}`"
    kind = prop.get("type", "any")
    if kind == "array":
        items = prop.get("items") or prop.get("prefixItems")
        if isinstance(items, list):
            return "[" + ", ".join(_type(i) for i in items) + "]"
        return f"list of {_type(items or {})}"
    if kind == "object":
        return "mapping"
    return str(kind)


def _unit_hint(prop: dict[str, Any]) -> str:
    for option in prop.get("anyOf", []):
        text = str(option.get("description", ""))
        if "with its unit" in text:
            return text.split(" with its unit")[0]
    return ""


def _bounds(prop: dict[str, Any]) -> str:
    marks = []
    for key, sign in (("minimum", ">="), ("exclusiveMinimum", ">"), ("maximum", "<=")):
        if key in prop:
            marks.append(f"{sign} {prop[key]}")
    for key, sign in (("exclusiveMaximum", "<"), ("maxItems", "at most"), ("minItems", "at least")):
        if key in prop:
            marks.append(f"{sign} {prop[key]}")
    if "pattern" in prop and "with its unit" not in prop.get("description", ""):
        marks.append(f"pattern `{prop['pattern']}`")
    return ", ".join(marks)


def _table(title: str, schema: dict[str, Any], defs: dict[str, Any]) -> list[str]:
    lines = [f"## {title}", ""]
    if schema.get("description"):
        lines += [" ".join(str(schema["description"]).split()), ""]
    props: dict[str, Any] = schema.get("properties", {})
    if not props:
        return lines
    required = set(schema.get("required", []))
    lines += ["| key | type | required | default | bounds | meaning |", "|---|---|---|---|---|---|"]
    for key, prop in props.items():
        text = prop.get("description", "")
        if not text and "$ref" in prop:
            text = defs.get(prop["$ref"].rsplit("/", 1)[-1], {}).get("description", "")
        meaning = " ".join(str(text).split())
        hint = _unit_hint(prop)
        kind = _type(prop) + (f" ({hint})" if hint else "")
        default = f"`{prop['default']}`" if "default" in prop else ""
        req = "yes" if key in required else ""
        row = [f"`{key}`", kind, req, default, _bounds(prop), meaning]
        lines.append(
            "| " + " | ".join(c.replace("|", "\\|") if c != kind else c for c in row) + " |"
        )
    lines.append("")
    return lines


def render_reference() -> str:
    """The reference page as Markdown."""
    schema = robot_schema()
    defs: dict[str, Any] = schema.get("$defs", {})
    lines = [_INTRO, *_table("RobotDescription (the file)", schema, defs)]
    for name in sorted(defs):
        lines += _table(name, defs[name], defs)
    return "\n".join(lines).rstrip() + "\n"


if __name__ == "__main__":  # pragma: no cover
    sys.stdout.write(render_reference())
