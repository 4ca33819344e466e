"""The JSON Schema of tree files (``pirate-bt schema tree``), built from the registry.

Each registered node type contributes its pydantic ``Params`` schema, so the
schema an editor sees always matches what the loader accepts. A parameter
reference (``$name``) is allowed wherever a node parameter is.
"""

from __future__ import annotations

import copy
from typing import Any

from pirate_bt.treefile.params import ParamDecl
from pirate_bt.treefile.registry import Registry, default_registry
from pirate_bt.treefile.spec import BLACKBOARD_TYPES

__all__ = ["tree_schema"]

_REF = {"type": "string", "pattern": r"^\$[A-Za-z_][A-Za-z0-9_]*$", "description": "parameter"}
_NODE = {"$ref": "#/$defs/node"}
_NAME = {"type": "string", "minLength": 1, "description": "node name, unique among siblings"}


def _common(kind: str) -> dict[str, Any]:
    return {
        "type": {"const": kind},
        "name": _NAME,
        "description": {"type": "string"},
    }


def _structural() -> dict[str, Any]:
    children = {"type": "array", "minItems": 1, "items": _NODE}
    memory = {"anyOf": [{"type": "boolean"}, _REF], "description": "resume a RUNNING child"}
    return {
        "sequence": {"memory": memory, "children": children},
        "selector": {"memory": memory, "children": children},
        "parallel": {
            "policy": {"enum": ["all", "one", "selected"]},
            "synchronise": {"anyOf": [{"type": "boolean"}, _REF]},
            "selected": {"type": "array", "items": {"type": "string"}},
            "children": children,
        },
        "eternal_guard": {"conditions": children, "child": _NODE},
        "subtree": {
            "ref": {"type": "string", "description": "NAME, FILE.yaml or FILE.yaml#NAME"},
            "params": {"type": "object"},
        },
    }


def tree_schema(registry: Registry | None = None) -> dict[str, Any]:
    """The JSON Schema (draft 2020-12) of a tree file."""
    reg = registry or default_registry()
    defs: dict[str, Any] = {}
    variants: list[dict[str, Any]] = []
    required = {"sequence": ["children"], "selector": ["children"], "parallel": ["children"]}
    required |= {"eternal_guard": ["conditions", "child"], "subtree": ["ref"]}
    for kind, fields in _structural().items():
        variants.append(
            {
                "type": "object",
                "title": kind,
                "properties": {**_common(kind), **fields},
                "required": ["type", *required[kind]],
                "additionalProperties": False,
            }
        )
    simple: list[str] = []
    for kind in reg.names():
        cls = reg.get(kind)
        schema = copy.deepcopy(cls.Params.model_json_schema(ref_template="#/$defs/{model}"))
        defs.update(schema.pop("$defs", {}))
        props: dict[str, Any] = {}
        for key, sub in schema.get("properties", {}).items():
            props[key] = {"anyOf": [sub, _REF], "description": sub.get("description", "")}
        if cls.kind == "decorator":
            props["child"] = _NODE
        req = ["type", *schema.get("required", [])]
        if cls.kind == "decorator":
            req.append("child")
        elif not schema.get("required"):
            simple.append(kind)
        variants.append(
            {
                "type": "object",
                "title": kind,
                "description": (cls.__doc__ or "").strip().split("\n")[0],
                "properties": {**_common(kind), **props},
                "required": req,
                "additionalProperties": False,
            }
        )
    variants.append({"enum": simple, "description": "a leaf without parameters, by name"})
    defs["node"] = {"anyOf": variants}
    tree_body = {
        "type": "object",
        "properties": {
            "description": {"type": "string"},
            "params": {
                "type": "object",
                # what $name can name (an editor flags 'café:', as the loader refuses it)
                "propertyNames": {"pattern": "^[A-Za-z_][A-Za-z0-9_]*$"},
                "additionalProperties": ParamDecl.model_json_schema(),
            },
            "root": _NODE,
        },
        "required": ["root"],
        "additionalProperties": False,
    }
    return {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "title": "pirate_bt behaviour tree",
        "type": "object",
        "properties": {
            "name": {"type": "string"},
            "description": {"type": "string"},
            "params": tree_body["properties"]["params"],  # type: ignore[index]
            "blackboard": {
                "type": "object",
                "additionalProperties": {
                    "type": ["object", "null"],
                    "properties": {
                        "type": {"enum": list(BLACKBOARD_TYPES)},
                        "default": {},
                        "external": {"type": "boolean"},
                        "description": {"type": "string"},
                    },
                    "additionalProperties": False,
                },
            },
            "root": _NODE,
            "subtrees": {"type": "object", "additionalProperties": tree_body},
        },
        "required": ["root"],
        "additionalProperties": False,
        "$defs": defs,
    }
