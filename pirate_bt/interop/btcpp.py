"""BehaviorTree.CPP v4 XML, both ways: what Groot2 opens, edits and saves.

BehaviorTree.CPP (BT.CPP) describes a tree as XML (``BTCPP_format="4"``): one
``<BehaviorTree ID=...>`` per tree, ``<SubTree ID=.../>`` to include another
tree with its ports remapped, and a ``<TreeNodesModel>`` that tells an editor
which node types exist and which ports (parameters) they take. A pirate_bt tree
file maps onto that closely:

- the tree file's root and every subtree it uses (in the same file or in
  another) become one ``<BehaviorTree>`` each; a subtree's declared parameters
  become the ports of its ``<SubTree>`` model, and ``params:`` at the call site
  become the ``<SubTree>``'s remapped ports;
- a whole-value parameter ``$roll`` becomes the blackboard pointer ``{roll}``,
  which is how a BT.CPP subtree reads its ports;
- composites and decorators go to BT.CPP's own nodes only where the semantics
  match (:data:`TO_BTCPP`; ``docs/interop.md`` has the table and the reasons);
  everything else, every leaf included, stays a pirate_bt node, declared in the
  ``<TreeNodesModel>`` with ports derived from the node class's parameter model
  (:func:`node_models`), never from a hand-written list.

A value is written as text in the port's own terms: ``0.7 N*m`` for a torque,
``3`` for an integer, ``true`` for a boolean. Values with no plain-text form
(lists, comparisons, a number where a string could also be meant) use BT.CPP's
``json:`` prefix. Reading back (:func:`import_xml`) undoes exactly that, so
YAML → XML → YAML keeps the structure and every parameter.

Reading refuses, at ``file:line:column``, what cannot become a pirate_bt tree:
malformed XML, DTDs and entities (see :mod:`pirate_bt.interop.btcpp_xml`),
unknown node types and ports, BT.CPP nodes with no pirate_bt counterpart,
scripts (``_skipIf`` and friends), missing IDs and subtrees that include each
other.
"""

from __future__ import annotations

import difflib
import json
import logging
import math
import os
import tempfile
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from dataclasses import dataclass
from enum import Enum
from pathlib import Path
from typing import Any, Final, get_args

import yaml
from pydantic import BaseModel, ValidationError

from pirate_bt.behaviours.base import NodeMixin
from pirate_bt.errors import InputError, LocatedError, ValidationFailed
from pirate_bt.interop.btcpp_xml import XmlElement, parse_xml, write_atomic
from pirate_bt.treefile.params import PARAM_RE, SI_UNITS, ParamType
from pirate_bt.treefile.registry import Registry, default_registry
from pirate_bt.yamlfile import YamlDocument, load_yaml, validation_problems

__all__ = [
    "BTCPP_FORMAT",
    "FROM_BTCPP",
    "TO_BTCPP",
    "NodeModel",
    "PortModel",
    "decode_value",
    "encode_value",
    "export_xml",
    "import_xml",
    "node_models",
    "tree_to_xml",
    "xml_to_tree",
]

_log = logging.getLogger(__name__)

BTCPP_FORMAT: Final = "4"

#: pirate_bt node type -> (BT.CPP node ID, our parameter -> BT.CPP port), for the
#: registered nodes whose behaviour BT.CPP's built-in node shares. Composites
#: (sequence, selector, parallel, eternal_guard) are chosen by their options in
#: :func:`_composite`. ``docs/interop.md`` explains each row, and the rows left out.
TO_BTCPP: Final[dict[str, tuple[str, dict[str, str]]]] = {
    "success": ("AlwaysSuccess", {}),
    "failure": ("AlwaysFailure", {}),
    "inverter": ("Inverter", {}),
    "failure_is_success": ("ForceSuccess", {}),
    "success_is_failure": ("ForceFailure", {}),
    "retry": ("RetryUntilSuccessful", {"attempts": "num_attempts"}),
    "repeat": ("Repeat", {"times": "num_cycles"}),
    "oneshot": ("RunOnce", {}),  # only with on: completion (then_skip="false")
}

#: BT.CPP node ID -> pirate_bt node type, for reading XML back.
FROM_BTCPP: Final[dict[str, str]] = {
    "Sequence": "sequence",
    "ReactiveSequence": "sequence",
    "Fallback": "selector",
    "ReactiveFallback": "selector",
    "Parallel": "parallel",
    **{btcpp: ours for ours, (btcpp, _) in TO_BTCPP.items()},
}

# BT.CPP's built-in node IDs (4.8): none of our tree IDs may take one of these names.
_BTCPP_BUILTINS: Final = frozenset(
    {
        "AlwaysFailure",
        "AlwaysSuccess",
        "AsyncFallback",
        "AsyncSequence",
        "Delay",
        "EntryUpdated",
        "Fallback",
        "ForceFailure",
        "ForceSuccess",
        "IfThenElse",
        "Inverter",
        "KeepRunningUntilFailure",
        "LoopBool",
        "LoopDouble",
        "LoopInt",
        "LoopString",
        "ManualSelector",
        "Parallel",
        "ParallelAll",
        "Precondition",
        "ReactiveFallback",
        "ReactiveSequence",
        "Repeat",
        "RetryUntilSuccessful",
        "RunOnce",
        "Script",
        "ScriptCondition",
        "Sequence",
        "SequenceWithMemory",
        "SetBlackboard",
        "SkipUnlessUpdated",
        "Sleep",
        "SubTree",
        "Switch2",
        "Switch3",
        "Switch4",
        "Switch5",
        "Switch6",
        "Timeout",
        "TryCatch",
        "UnsetBlackboard",
        "WaitValueUpdate",
        "WasEntryUpdated",
        "WhileDoElse",
    }
)
# BT.CPP's pre- and post-condition script attributes: pirate_bt has no scripts.
_SCRIPT_ATTRS: Final = frozenset(
    {"_failureIf", "_successIf", "_skipIf", "_while", "_onHalted", "_onFailure", "_onSuccess"}
    | {"_post"}
)
_MODEL_TAGS: Final = ("Action", "Condition", "Control", "Decorator", "SubTree")
_HINT: Final = "_pirate_bt"  # marks a ReactiveSequence that was an eternal_guard
_DIMENSION_TYPE: Final = {dim: kind for kind, (dim, _) in SI_UNITS.items()}
_PARAM_TYPES: Final = frozenset(get_args(ParamType))


# -- node models ---------------------------------------------------------------------


@dataclass(frozen=True)
class PortModel:
    """One port (parameter) of a node type.

    Attributes:
        name: The parameter's name.
        type: ``integer``, ``number``, ``boolean``, ``string``, a quantity
            (``angle``, ``duration``, ``torque``, ...), ``scalar`` (any of the
            first four) or ``json`` (a list or mapping, written with ``json:``).
        description: What the parameter means.
        default: The default as port text, or ``None`` if the port is required.
        choices: The allowed values of a string port, if limited.
    """

    name: str
    type: str
    description: str = ""
    default: str | None = None
    choices: tuple[str, ...] = ()


@dataclass(frozen=True)
class NodeModel:
    """A node type as BT.CPP's ``<TreeNodesModel>`` declares it.

    Attributes:
        id: The node ID (the pirate_bt type name).
        category: ``Action``, ``Condition``, ``Decorator`` or ``Control``.
        ports: The input ports.
        description: The node class's first docstring line.
    """

    id: str
    category: str
    ports: tuple[PortModel, ...]
    description: str = ""

    def port(self, name: str) -> PortModel | None:
        """The port called ``name``, if there is one."""
        return next((p for p in self.ports if p.name == name), None)


def _quantity_schemas() -> dict[str, str]:
    from pirate_bt.units import _DISPLAY, _json_schema

    return {json.dumps(_json_schema(dim), sort_keys=True): dim for dim in _DISPLAY}


def _schema_type(prop: Mapping[str, Any], defs: Mapping[str, Any]) -> tuple[str, tuple[str, ...]]:
    """(port type, choices) of one property of a parameter model's JSON schema."""
    quantity = _quantity_schemas().get(json.dumps(dict(prop), sort_keys=True))
    if quantity is None and "anyOf" in prop:
        bare = {k: v for k, v in prop.items() if k in ("anyOf",)}
        quantity = _quantity_schemas().get(json.dumps(bare, sort_keys=True))
    if quantity is not None:
        return _DIMENSION_TYPE.get(quantity, quantity), ()
    if "$ref" in prop:
        return _schema_type(defs[str(prop["$ref"]).rsplit("/", 1)[-1]], defs)
    if "allOf" in prop and len(prop["allOf"]) == 1:
        return _schema_type(prop["allOf"][0], defs)
    if "anyOf" in prop:
        options = [o for o in prop["anyOf"] if o.get("type") != "null"]
        if len(options) == 1:
            return _schema_type(options[0], defs)
        kinds = [o.get("type") for o in options]
        if all(k in ("boolean", "integer", "number", "string") for k in kinds) and all(
            "$ref" not in o for o in options
        ):
            return "scalar", ()
        return "json", ()
    if "enum" in prop:
        return "string", tuple(str(e) for e in prop["enum"])
    kind = prop.get("type")
    if kind in ("integer", "number", "boolean", "string"):
        return str(kind), ()
    return "json", ()


def _default_text(value: Any, port_type: str) -> str | None:
    if value is None:
        return None
    if port_type in SI_UNITS and isinstance(value, int | float) and not isinstance(value, bool):
        return f"{value!r} {SI_UNITS[port_type][1]}"
    return encode_value(value, port_type)


def _plain(value: Any) -> Any:
    """A default value as plain JSON data (enums by value, models dumped)."""
    if isinstance(value, Enum):
        return value.value
    if isinstance(value, BaseModel):
        return value.model_dump(mode="json")
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    return value


def _ports(params: type[BaseModel]) -> tuple[PortModel, ...]:
    schema = params.model_json_schema()
    defs = schema.get("$defs", {})
    out: list[PortModel] = []
    for name, info in params.model_fields.items():
        prop = schema.get("properties", {}).get(name, {})
        port_type, choices = _schema_type(prop, defs)
        default = (
            None
            if info.is_required()
            else _default_text(_plain(info.get_default(call_default_factory=True)), port_type)
        )
        if not info.is_required() and default is None:
            default = ""  # optional with no value: an empty default keeps the port optional
        out.append(PortModel(name, port_type, info.description or "", default, choices))
    return tuple(out)


def _category(cls: type[NodeMixin]) -> str:
    if cls.kind == "decorator":
        return "Decorator"
    try:
        outcomes = cls.outcomes(None)
    except Exception:  # outcomes that depend on the parameters: an action
        return "Action"
    return "Condition" if outcomes == frozenset({"success", "failure"}) else "Action"


_PARALLEL_MODEL: Final = NodeModel(
    "parallel",
    "Control",
    (
        PortModel(
            "policy",
            "string",
            "success on all, one or selected children",
            "all",
            ("all", "one", "selected"),
        ),
        PortModel("synchronise", "boolean", "children that succeeded are not ticked again", ""),
        PortModel("selected", "json", "with policy selected: the names of the children", ""),
    ),
    "py_trees' Parallel (the policies BT.CPP's Parallel does not share)",
)


def node_models(registry: Registry | None = None) -> dict[str, NodeModel]:
    """Every pirate_bt node type as a BT.CPP node model, derived from the registry.

    Each registered class gives its category (decorator, condition or action)
    and one port per field of its ``Params`` model, typed and described from
    that model. ``parallel`` is added as a control node (for the policies that
    BT.CPP's ``Parallel`` does not share).

    Raises:
        InputError: a registered node class cannot be imported.
    """
    reg = registry or default_registry()
    models: dict[str, NodeModel] = {}
    for name in reg.names():
        try:
            cls = reg.get(name)
        except ImportError as exc:
            raise InputError(f"node type {name!r} cannot be loaded: {exc}") from None
        doc = (cls.__doc__ or "").strip().splitlines()
        models[name] = NodeModel(name, _category(cls), _ports(cls.Params), doc[0] if doc else "")
    models["parallel"] = _PARALLEL_MODEL
    return models


# -- values ----------------------------------------------------------------------------


def _json(value: Any) -> str:
    return "json:" + json.dumps(value, ensure_ascii=False, separators=(",", ":"))


def encode_value(value: Any, port_type: str) -> str:
    """A YAML value as BT.CPP port text.

    ``$name`` becomes ``{name}`` (a blackboard pointer: the subtree's port);
    ``$$text`` the literal ``$text``; a plain value its text when the port's type
    says how to read it back, else ``json:`` and the value as JSON.
    """
    if isinstance(value, str):
        match = PARAM_RE.match(value)
        if match:
            return "{" + match["name"] + "}"
        if value.startswith("$$"):
            value = value[1:]
        if (value.startswith("{") and value.endswith("}")) or value.startswith("json:"):
            return _json(value)  # would read as a pointer or as JSON
        return str(value)
    if isinstance(value, bool):
        return ("true" if value else "false") if port_type == "boolean" else _json(value)
    if isinstance(value, int) and port_type in ("integer", "number"):
        return str(value)
    if isinstance(value, float) and port_type == "number" and math.isfinite(value):
        return repr(value)
    return _json(value)


def decode_value(text: str, port_type: str, port: str = "") -> Any:
    """BT.CPP port text as the YAML value (the inverse of :func:`encode_value`).

    Raises:
        ValueError: the text does not fit the port's type.
    """
    if text.startswith("json:"):
        try:
            return json.loads(text[5:])
        except json.JSONDecodeError as exc:
            raise ValueError(f"bad json: value: {exc.msg}") from None
    if len(text) >= 3 and text[0] == "{" and text[-1] == "}":
        name = port if text == "{=}" else text[1:-1]
        if not name.isidentifier():
            raise ValueError(f"blackboard pointer {text!r}: pirate_bt parameters are identifiers")
        return "$" + name
    if text.startswith("$"):
        return "$" + text
    if port_type == "integer":
        try:
            return int(text)
        except ValueError:
            raise ValueError(f"expected an integer, got {text!r}") from None
    if port_type == "number":
        try:
            return float(text)
        except ValueError:
            raise ValueError(f"expected a number, got {text!r}") from None
    if port_type == "boolean":
        lowered = text.strip().lower()
        if lowered in ("true", "1"):
            return True
        if lowered in ("false", "0"):
            return False
        raise ValueError(f"expected true or false, got {text!r}")
    return text


# -- export ------------------------------------------------------------------------------


def _located(doc: YamlDocument, path: tuple[str | int, ...], message: str) -> LocatedError:
    return LocatedError(message, doc.locator.locate(path))


class _Exporter:
    """Walks the tree files (as written, before parameters are substituted)."""

    def __init__(self, registry: Registry, models: dict[str, NodeModel]) -> None:
        self.registry = registry
        self.models = models
        self.docs: dict[str, YamlDocument] = {}
        self.ids: dict[str, str] = {}  # file#name -> BehaviorTree ID
        self.trees: list[ET.Element] = []
        self.params: dict[str, tuple[YamlDocument, tuple[str | int, ...], Any]] = {}
        self.taken = set(models) | set(_BTCPP_BUILTINS)

    def document(self, path: Path) -> YamlDocument:
        key = str(path.resolve())
        if key not in self.docs:
            self.docs[key] = load_yaml(path)
        return self.docs[key]

    def tree(self, doc: YamlDocument, name: str, tree_id: str | None = None) -> str:
        ident = f"{Path(doc.file).resolve()}#{name}"
        if ident in self.ids:
            return self.ids[ident]
        data = doc.data
        if not tree_id:
            if name:
                tree_id = name if doc is self.root_doc else f"{self.file_id(doc)}.{name}"
            else:
                tree_id = self.file_id(doc)
        base, n = tree_id, 1
        while tree_id in self.taken:
            n += 1
            tree_id = f"{base}_{n}"
        self.taken.add(tree_id)
        self.ids[ident] = tree_id
        prefix: tuple[str | int, ...] = ("subtrees", name) if name else ()
        body = data["subtrees"][name] if name else data
        element = ET.Element("BehaviorTree", {"ID": tree_id})
        if isinstance(body.get("description"), str):
            element.set("_description", body["description"])
        self.trees.append(element)
        self.params[tree_id] = (doc, (*prefix, "params"), body.get("params") or {})
        element.append(self.node(doc, (*prefix, "root"), body["root"]))
        return tree_id

    def file_id(self, doc: YamlDocument) -> str:
        name = doc.data.get("name")
        return name if isinstance(name, str) and name else Path(doc.file).stem

    def node(self, doc: YamlDocument, path: tuple[str | int, ...], raw: Any) -> ET.Element:
        if isinstance(raw, str):
            raw = {"type": raw}
        kind: str = raw["type"]
        if kind == "subtree":
            element = self.subtree(doc, path, raw)
        elif kind in ("sequence", "selector", "parallel", "eternal_guard"):
            element = self.composite(doc, path, raw)
        else:
            element = self.registered(doc, path, raw)
        if isinstance(raw.get("description"), str):
            element.set("_description", raw["description"])
        return element

    def subtree(self, doc: YamlDocument, path: tuple[str | int, ...], raw: Any) -> ET.Element:
        ref: str = raw["ref"]
        file_part, hash_sign, tree_name = ref.partition("#")
        if file_part.endswith((".yaml", ".yml")):
            target = self.document(Path(doc.file).parent / file_part)
            name = tree_name if hash_sign else ""
        else:
            target, name = doc, file_part
        tree_id = self.tree(target, name)
        element = ET.Element("SubTree", {"ID": tree_id})
        if raw.get("name"):
            element.set("name", raw["name"])
        decls = self.declared(target, name)
        for key, value in (raw.get("params") or {}).items():
            element.set(key, encode_value(value, decls.get(key, "string")))
        return element

    def declared(self, doc: YamlDocument, name: str) -> dict[str, str]:
        body = doc.data["subtrees"][name] if name else doc.data
        out: dict[str, str] = {}
        for key, decl in (body.get("params") or {}).items():
            out[key] = decl if isinstance(decl, str) else str(decl.get("type", "string"))
        return out

    def composite(self, doc: YamlDocument, path: tuple[str | int, ...], raw: Any) -> ET.Element:
        kind = raw["type"]
        attrs: dict[str, str] = {}
        if kind == "eternal_guard":
            tag = "ReactiveSequence"
            kids = [*raw["conditions"], raw["child"]]
            paths = [
                *((*path, "conditions", i) for i in range(len(raw["conditions"]))),
                (*path, "child"),
            ]
            attrs[_HINT] = "eternal_guard"
        else:
            kids = raw["children"]
            paths = [(*path, "children", i) for i in range(len(kids))]
            if kind in ("sequence", "selector"):
                memory = raw.get("memory", kind == "sequence")
                if not isinstance(memory, bool):
                    raise _located(
                        doc,
                        (*path, "memory"),
                        "memory: a parameter cannot choose between BT.CPP's node types;"
                        " write true or false",
                    )
                tag = {
                    ("sequence", True): "Sequence",
                    ("sequence", False): "ReactiveSequence",
                    ("selector", True): "Fallback",
                    ("selector", False): "ReactiveFallback",
                }[(kind, memory)]
            else:
                tag, attrs = self.parallel(raw)
        element = ET.Element(tag)
        if raw.get("name"):
            element.set("name", raw["name"])
        for key, value in attrs.items():
            element.set(key, value)
        for kid_path, kid in zip(paths, kids, strict=True):
            element.append(self.node(doc, kid_path, kid))
        return element

    def parallel(self, raw: Mapping[str, Any]) -> tuple[str, dict[str, str]]:
        policy = raw.get("policy", "all")
        sync = raw.get("synchronise", policy != "one")
        if "selected" not in raw:
            if policy == "all" and sync is True:
                return "Parallel", {"success_count": "-1", "failure_count": "1"}
            if policy == "one" and sync is False:
                return "Parallel", {"success_count": "1", "failure_count": "1"}
        attrs: dict[str, str] = {}
        for key in ("policy", "synchronise", "selected"):
            if key in raw:
                port = _PARALLEL_MODEL.port(key)
                attrs[key] = encode_value(raw[key], port.type if port else "string")
        return "parallel", attrs

    def registered(self, doc: YamlDocument, path: tuple[str | int, ...], raw: Any) -> ET.Element:
        kind: str = raw["type"]
        model = self.models[kind]
        params = {k: v for k, v in raw.items() if k not in ("type", "name", "description", "child")}
        tag: str = kind
        renames: dict[str, str] = {}
        if kind in TO_BTCPP and (
            kind != "oneshot" or params.get("on", "completion") == "completion"
        ):
            tag, renames = TO_BTCPP[kind]
            if kind == "oneshot":
                params = {"then_skip": False}
        element = ET.Element(tag)
        if raw.get("name"):
            element.set("name", raw["name"])
        for key, value in params.items():
            port = model.port(key)
            port_type = port.type if port else "boolean"
            element.set(renames.get(key, key), encode_value(value, port_type))
        if "child" in raw:
            element.append(self.node(doc, (*path, "child"), raw["child"]))
        return element

    root_doc: YamlDocument


def _model_element(model: NodeModel) -> ET.Element:
    element = ET.Element(model.category, {"ID": model.id})
    for port in model.ports:
        attrs = {"name": port.name, "type": port.type}
        if port.default is not None:
            attrs["default"] = port.default
        if port.choices:
            attrs["choices"] = ";".join(port.choices)
        child = ET.SubElement(element, "input_port", attrs)
        child.text = port.description or None
    return element


def _subtree_model(tree_id: str, decls: Mapping[str, Any], given: Mapping[str, str]) -> ET.Element:
    element = ET.Element("SubTree", {"ID": tree_id})
    for name, decl in decls.items():
        decl = {"type": decl} if isinstance(decl, str) else dict(decl)
        kind = str(decl.get("type", "string"))
        attrs = {"name": name, "type": kind}
        if name in given:
            attrs["default"] = given[name]
        elif decl.get("default") is not None:
            attrs["default"] = encode_value(decl["default"], kind)
        if decl.get("example") is not None:
            attrs["example"] = encode_value(decl["example"], kind)
        if decl.get("choices"):
            attrs["choices"] = _json(list(decl["choices"]))
        port = ET.SubElement(element, "input_port", attrs)
        port.text = str(decl["description"]) if decl.get("description") else None
    return element


def tree_to_xml(
    path: str | Path,
    params: Mapping[str, str] | None = None,
    registry: Registry | None = None,
) -> str:
    """The tree file at ``path`` (and every file it uses) as BT.CPP v4 XML text.

    The tree is checked first, with the loader (a parameter without a default
    takes ``params``, then its ``example``). Values given in ``params`` become
    the defaults of the main tree's ports.

    Raises:
        ValidationFailed: the tree does not load.
        LocatedError: the tree uses something XML cannot say.
    """
    from pirate_bt.treefile import load_tree

    reg = registry or default_registry()
    source = Path(path)
    given = dict(params or {})
    loaded = load_tree(source, params=given, params_from_text=True, use_examples=True, registry=reg)
    exporter = _Exporter(reg, node_models(reg))
    exporter.root_doc = exporter.document(source)
    main_id = exporter.tree(exporter.root_doc, "", loaded.name)
    written_name = exporter.root_doc.data.get("name")
    if not isinstance(written_name, str):  # the file has no name: say so (empty)
        exporter.trees[0].set("_name", "")
    elif main_id != written_name:  # the name is a node type's: keep it beside the ID
        exporter.trees[0].set("_name", written_name)
    root = ET.Element("root", {"BTCPP_format": BTCPP_FORMAT, "main_tree_to_execute": main_id})
    board = {key: decl.model_dump(exclude_defaults=True) for key, decl in loaded.blackboard.items()}
    if board:
        exporter.trees[0].set("_blackboard", _json(board))
    root.extend(exporter.trees)
    models = ET.SubElement(root, "TreeNodesModel")
    for name in sorted(exporter.models):
        models.append(_model_element(exporter.models[name]))
    for element in exporter.trees:
        tree_id = element.get("ID", "")
        _doc, _where, decls = exporter.params[tree_id]
        models.append(_subtree_model(tree_id, decls, given if tree_id == main_id else {}))
    ET.indent(root, space="  ")
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, "unicode") + "\n"


def export_xml(
    tree_path: str | Path,
    out_path: str | Path,
    params: Mapping[str, str] | None = None,
    registry: Registry | None = None,
) -> Path:
    """Write ``tree_path`` as BT.CPP v4 XML to ``out_path`` (atomically); see :func:`tree_to_xml`.

    Returns:
        The file written.
    """
    text = tree_to_xml(tree_path, params, registry)
    return write_atomic(Path(out_path), text)


# -- import ------------------------------------------------------------------------------


def _suggest(name: str, known: list[str]) -> str:
    close = difflib.get_close_matches(name, known, n=2)
    return f"; did you mean {' or '.join(map(repr, close))}?" if close else ""


class _Importer:
    def __init__(self, root: XmlElement, registry: Registry) -> None:
        self.root = root
        self.registry = registry
        self.models = node_models(registry)
        self.trees: dict[str, XmlElement] = {}
        self.subtree_models: dict[str, XmlElement] = {}

    def read(self) -> dict[str, Any]:
        root = self.root
        if root.tag != "root":
            raise root.error(f"expected <root>, found <{root.tag}>")
        fmt = root.attrs.get("BTCPP_format")
        if fmt != BTCPP_FORMAT:
            raise root.error(
                f"BTCPP_format={fmt!r}: only BehaviorTree.CPP version 4 files are read"
                " (convert version 3 files with BT.CPP's convert_v3_to_v4.py)"
                if fmt
                else 'missing BTCPP_format="4" on <root>'
            )
        models_seen = False
        for child in root.children:
            if child.tag == "BehaviorTree":
                tree_id = child.attrs.get("ID")
                if not tree_id:
                    raise child.error("<BehaviorTree> without an ID")
                if tree_id in self.trees:
                    raise child.error(
                        f"a second <BehaviorTree ID={tree_id!r}> (first at"
                        f" {self.trees[tree_id].location})"
                    )
                if tree_id in self.models or tree_id in _BTCPP_BUILTINS:
                    raise child.error(f"tree ID {tree_id!r} is the name of a node type")
                if len(child.children) != 1:
                    raise child.error(
                        f"<BehaviorTree ID={tree_id!r}> must have exactly one child,"
                        f" not {len(child.children)}"
                    )
                self.trees[tree_id] = child
            elif child.tag == "TreeNodesModel":
                if models_seen:
                    raise child.error("a second <TreeNodesModel>")
                models_seen = True
                self.read_models(child)
            elif child.tag == "include":
                raise child.error("<include> is not supported: put every tree in one file")
            else:
                raise child.error(
                    f"unexpected <{child.tag}> under <root>; expected <BehaviorTree>"
                    " or <TreeNodesModel>"
                )
        if not self.trees:
            raise root.error("no <BehaviorTree> in the file")
        main = root.attrs.get("main_tree_to_execute")
        if main is None:
            if len(self.trees) > 1:
                raise root.error(
                    "several <BehaviorTree> and no main_tree_to_execute to say which one runs"
                )
            main = next(iter(self.trees))
        elif main not in self.trees:
            raise root.error(
                f"main_tree_to_execute={main!r}: no such <BehaviorTree>"
                + _suggest(main, list(self.trees))
            )
        self.check_cycles(main)
        main_tree = self.trees[main]
        out: dict[str, Any] = {}
        written_name = main_tree.attrs.get("_name", main)
        if written_name:  # empty: the tree file had no name (it takes the file's)
            out["name"] = written_name
        if "_description" in main_tree.attrs:
            out["description"] = main_tree.attrs["_description"]
        params = self.params(main)
        if params:
            out["params"] = params
        if "_blackboard" in main_tree.attrs:
            try:
                board = decode_value(main_tree.attrs["_blackboard"], "json")
            except ValueError as exc:
                raise main_tree.error(f"_blackboard: {exc}") from None
            if not isinstance(board, dict):
                raise main_tree.error("_blackboard: a JSON object of key -> declaration")
            out["blackboard"] = board
        out["root"] = self.node(main_tree.children[0])
        subtrees: dict[str, Any] = {}
        for tree_id, element in self.trees.items():
            if tree_id == main:
                continue
            body: dict[str, Any] = {}
            if "_description" in element.attrs:
                body["description"] = element.attrs["_description"]
            params = self.params(tree_id)
            if params:
                body["params"] = params
            body["root"] = self.node(element.children[0])
            subtrees[tree_id] = body
        if subtrees:
            out["subtrees"] = subtrees
        return out

    def read_models(self, models: XmlElement) -> None:
        for model in models.children:
            if model.tag not in _MODEL_TAGS:
                raise model.error(
                    f"unexpected <{model.tag}> in <TreeNodesModel>; expected one of"
                    f" {', '.join(_MODEL_TAGS)}"
                )
            model_id = model.attrs.get("ID")
            if not model_id:
                raise model.error(f"<{model.tag}> in <TreeNodesModel> without an ID")
            if model.tag == "SubTree":
                self.subtree_models[model_id] = model
            elif model_id not in self.models:
                # A node type of another program: fine as long as no tree uses it.
                _log.info(
                    "%s: node model %r is not a pirate_bt node type", model.location, model_id
                )

    def check_cycles(self, main: str) -> None:
        state: dict[str, int] = {}  # 1: on the stack, 2: done

        def visit(tree_id: str, chain: list[str]) -> None:
            state[tree_id] = 1
            stack = [self.trees[tree_id]]
            while stack:
                element = stack.pop()
                stack.extend(element.children)
                if element.tag != "SubTree":
                    continue
                target = element.attrs.get("ID")
                if not target:
                    raise element.error("<SubTree> without an ID")
                if target not in self.trees:
                    raise element.error(
                        f"<SubTree ID={target!r}>: no such <BehaviorTree>"
                        + _suggest(target, list(self.trees))
                    )
                if state.get(target) == 1:
                    loop = " -> ".join([*chain[chain.index(target) :], target])
                    raise element.error(f"recursive subtree: {loop}")
                if state.get(target) is None:
                    visit(target, [*chain, target])
            state[tree_id] = 2

        visit(main, [main])
        for tree_id in self.trees:
            if tree_id not in state:
                visit(tree_id, [tree_id])

    def params(self, tree_id: str) -> dict[str, Any]:
        model = self.subtree_models.get(tree_id)
        if model is None:
            return {}
        out: dict[str, Any] = {}
        for port in model.children:
            if port.tag != "input_port":
                raise port.error(
                    f"<{port.tag}>: a pirate_bt subtree takes input ports (its parameters) only"
                )
            name = port.attrs.get("name", "")
            if not name.isidentifier():
                raise port.error(f"port name {name!r} must be an identifier")
            kind = port.attrs.get("type", "string")
            if kind not in _PARAM_TYPES:
                raise port.error(
                    f"port {name!r}: type {kind!r} is not a pirate_bt parameter type"
                    f" ({', '.join(sorted(_PARAM_TYPES))})"
                )
            decl: dict[str, Any] = {"type": kind}
            try:
                for key in ("default", "example"):
                    if key in port.attrs:
                        decl[key] = decode_value(port.attrs[key], kind, name)
                if "choices" in port.attrs:
                    decl["choices"] = decode_value(port.attrs["choices"], "json")
            except ValueError as exc:
                raise port.error(f"port {name!r}: {exc}") from None
            description = port.attrs.get("description") or port.text.strip()
            if description:
                decl["description"] = description
            out[name] = decl
        return out

    def node(self, element: XmlElement) -> dict[str, Any]:
        tag = element.tag
        attrs = dict(element.attrs)
        if tag in ("Action", "Condition", "Control", "Decorator"):
            tag = attrs.pop("ID", "")
            if not tag:
                raise element.error(f"<{element.tag}> without an ID")
        for key in attrs:
            if key in _SCRIPT_ATTRS:
                raise element.error(
                    f"{key}: BT.CPP scripts are not supported; use pirate_bt's guard"
                    " decorators (skip_if, failure_if, while)"
                )
        out: dict[str, Any] = {}
        name = attrs.pop("name", None)
        description = attrs.pop("_description", None)
        hint = attrs.pop(_HINT, None)
        ports = {k: v for k, v in attrs.items() if not k.startswith("_") and k != "ID"}
        if tag == "SubTree":
            out = self.subtree(element, ports, name)
        elif tag in FROM_BTCPP and tag not in self.models:
            out = self.builtin(element, tag, ports, name, hint)
        elif tag in self.models:
            out = self.registered(element, tag, ports, name)
        elif tag in _BTCPP_BUILTINS:
            raise element.error(
                f"BT.CPP node {tag!r} has no pirate_bt counterpart (see docs/interop.md)"
            )
        else:
            known = sorted({*self.models, *FROM_BTCPP})
            raise element.error(f"unknown node type {tag!r}" + _suggest(tag, known))
        if description is not None:
            out["description"] = description
        return out

    def named(self, kind: str, name: str | None) -> dict[str, Any]:
        return {"type": kind, "name": name} if name is not None else {"type": kind}

    def subtree(
        self, element: XmlElement, ports: dict[str, str], name: str | None
    ) -> dict[str, Any]:
        if element.children:
            raise element.error("<SubTree> must not have children")
        target = element.attrs.get("ID", "")
        if element.attrs.get("_autoremap") not in (None, "false", "0"):
            raise element.error("_autoremap is not supported: remap each port explicitly")
        declared = self.params(target)
        out = self.named("subtree", name)
        out["ref"] = target
        given: dict[str, Any] = {}
        for key, text in ports.items():
            decl = declared.get(key)
            if decl is None:
                known = ", ".join(declared) or "none declared"
                raise element.error(
                    f"<SubTree ID={target!r}>: port {key!r} is not a parameter of {target!r}"
                    f" (parameters: {known}; declare them in <TreeNodesModel>)"
                )
            try:
                given[key] = decode_value(text, decl["type"], key)
            except ValueError as exc:
                raise element.error(f"{key}: {exc}") from None
        if given:
            out["params"] = given
        return out

    def children(self, element: XmlElement, least: int) -> list[dict[str, Any]]:
        if len(element.children) < least:
            raise element.error(f"<{element.tag}> needs at least {least} child(ren)")
        return [self.node(child) for child in element.children]

    def only_child(self, element: XmlElement) -> dict[str, Any]:
        if len(element.children) != 1:
            raise element.error(
                f"<{element.tag}> is a decorator: exactly one child, not {len(element.children)}"
            )
        return self.node(element.children[0])

    def builtin(
        self,
        element: XmlElement,
        tag: str,
        ports: dict[str, str],
        name: str | None,
        hint: str | None,
    ) -> dict[str, Any]:
        kind = FROM_BTCPP[tag]
        allowed = {
            "Parallel": {"success_count", "failure_count"},
            "RetryUntilSuccessful": {"num_attempts"},
            "Repeat": {"num_cycles"},
            "RunOnce": {"then_skip"},
        }.get(tag, set())
        for key in ports:
            if key not in allowed:
                known = ", ".join(sorted(allowed)) or "none"
                raise element.error(f"<{tag}> has no port {key!r} (ports: {known})")
        if hint == "eternal_guard" and tag == "ReactiveSequence":
            kids = self.children(element, 2)
            out = self.named("eternal_guard", name)
            out["conditions"] = kids[:-1]
            out["child"] = kids[-1]
            return out
        if hint is not None:
            raise element.error(f"{_HINT}={hint!r} is only known on a <ReactiveSequence>")
        out = self.named(kind, name)
        if tag in ("Sequence", "ReactiveSequence", "Fallback", "ReactiveFallback"):
            memory = tag in ("Sequence", "Fallback")
            if memory != (kind == "sequence"):
                out["memory"] = memory
            out["children"] = self.children(element, 1)
            return out
        if tag == "Parallel":
            counts = (ports.get("success_count", "-1"), ports.get("failure_count", "1"))
            if counts == ("-1", "1"):
                pass  # policy: all, synchronised (the defaults)
            elif counts == ("1", "1"):
                out["policy"] = "one"
            else:
                raise element.error(
                    f"<Parallel success_count={counts[0]!r} failure_count={counts[1]!r}>:"
                    " pirate_bt's parallel succeeds on all (-1, 1) or one (1, 1) child"
                )
            out["children"] = self.children(element, 1)
            return out
        if tag == "RunOnce":
            if ports.get("then_skip", "true").lower() not in ("false", "0"):
                raise element.error(
                    '<RunOnce> without then_skip="false" returns SKIPPED after the first'
                    " run, a status pirate_bt does not have"
                )
            out["child"] = self.only_child(element)
            return out
        renames = {btcpp: ours for ours, btcpp in TO_BTCPP[kind][1].items()}
        for key, text in ports.items():
            try:
                value = decode_value(text, "integer", key)
            except ValueError as exc:
                raise element.error(f"{key}: {exc}") from None
            if isinstance(value, int) and value < 1:
                raise element.error(
                    f"{key}={text!r}: pirate_bt's {kind} needs a count of at least 1"
                )
            out[renames[key]] = value
        if self.models[kind].category == "Decorator":
            out["child"] = self.only_child(element)
        elif element.children:
            raise element.error(f"<{tag}> is a leaf and takes no children")
        return out

    def registered(
        self, element: XmlElement, kind: str, ports: dict[str, str], name: str | None
    ) -> dict[str, Any]:
        model = self.models[kind]
        out = self.named(kind, name)
        params: dict[str, Any] = {}
        for key, text in ports.items():
            port = model.port(key)
            if port is None:
                known = ", ".join(p.name for p in model.ports) or "none"
                raise element.error(
                    f"{kind}: unknown port {key!r} (ports: {known})"
                    + _suggest(key, [p.name for p in model.ports])
                )
            try:
                params[key] = decode_value(text, port.type, key)
            except ValueError as exc:
                raise element.error(f"{kind}: {key}: {exc}") from None
        if kind != "parallel":
            self.check_params(element, kind, params)
        out.update(params)
        if model.category == "Decorator":
            out["child"] = self.only_child(element)
        elif model.category == "Control":
            out["children"] = self.children(element, 1)
        elif element.children:
            raise element.error(f"{kind!r} is a leaf and takes no children")
        return out

    def check_params(self, element: XmlElement, kind: str, params: dict[str, Any]) -> None:
        """Validate a node's parameters here, where the XML can be pointed at."""
        if _has_reference(params):
            return  # checked when the converted tree is loaded, with the values bound
        cls = self.registry.get(kind)
        try:
            cls.Params.model_validate(params, context={"units_required": True})
        except ValidationError as exc:
            problems = validation_problems(exc, params)
            where, message = problems[0] if problems else ((), str(exc))
            field = ".".join(str(p) for p in where)
            raise element.error(f"{kind}: {field + ': ' if field else ''}{message}") from None


def _has_reference(value: Any) -> bool:
    if isinstance(value, str):
        return PARAM_RE.match(value) is not None
    if isinstance(value, dict):
        return any(_has_reference(v) for v in value.values())
    if isinstance(value, list):
        return any(_has_reference(v) for v in value)
    return False


def xml_to_tree(path: str | Path, registry: Registry | None = None) -> dict[str, Any]:
    """Read a BT.CPP v4 XML file into the mapping of a pirate_bt tree file.

    Raises:
        InputError: the file cannot be read.
        LocatedError: anything that cannot become a pirate_bt tree, located.
    """
    root = parse_xml(Path(path))
    return _Importer(root, registry or default_registry()).read()


class _Dumper(yaml.SafeDumper):
    pass


def _str(dumper: yaml.SafeDumper, value: str) -> yaml.Node:
    style = "|" if "\n" in value else None
    return dumper.represent_scalar("tag:yaml.org,2002:str", value, style=style)


_Dumper.add_representer(str, _str)


def import_xml(
    xml_path: str | Path, out_path: str | Path, registry: Registry | None = None
) -> Path:
    """Convert a BT.CPP v4 XML file to a pirate_bt tree file, checked before it appears.

    The YAML is written beside ``out_path`` under a temporary name, loaded with
    the tree loader, and only then renamed to ``out_path``: a file that does not
    load is never left behind.

    Returns:
        The file written.

    Raises:
        LocatedError: the XML cannot be converted (at the XML's line and column).
        InputError: the converted tree does not load (the loader's message).
    """
    from pirate_bt.treefile import load_tree

    reg = registry or default_registry()
    source = Path(xml_path)
    data = xml_to_tree(source, reg)
    text = (
        f"# Converted from {source.name} (BehaviorTree.CPP v4 XML) by pirate-bt import btcpp.\n"
        + yaml.dump(data, Dumper=_Dumper, sort_keys=False, allow_unicode=True, width=100)
    )
    out = Path(out_path)
    folder = out.parent if str(out.parent) else Path(".")
    try:
        fd, tmp_name = tempfile.mkstemp(prefix=f".{out.stem}.", suffix=".yaml", dir=folder)
    except OSError as exc:
        raise InputError(f"{out}: cannot write: {exc.strerror or exc}") from None
    tmp = Path(tmp_name)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as stream:
            stream.write(text)
        try:
            load_tree(tmp, use_examples=True, registry=reg)
        except ValidationFailed as exc:
            first = exc.errors[0]
            raise InputError(
                f"{source}: the converted tree does not load: {first.message}"
                + (f" (and {len(exc.errors) - 1} more)" if len(exc.errors) > 1 else "")
            ) from None
        mask = os.umask(0o022)
        os.umask(mask)
        os.chmod(tmp, 0o666 & ~mask)
        os.replace(tmp, out)
    except OSError as exc:
        raise InputError(f"{out}: cannot write: {exc.strerror or exc}") from None
    finally:
        tmp.unlink(missing_ok=True)
    return out
