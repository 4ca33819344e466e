"""BehaviorTree.CPP v4 node models and port values: what export and import share.

The mapping tables between pirate_bt and BT.CPP node types (:data:`TO_BTCPP`,
:data:`FROM_BTCPP`, BT.CPP's built-in IDs), the node and port models derived from
the registry (:func:`node_models`), and the encoding of YAML values as port text
and back (:func:`encode_value`, :func:`decode_value`). The public names are
re-exported by :mod:`pirate_bt.interop.btcpp`.
"""

from __future__ import annotations

import json
import math
import re
import sys
from collections.abc import Mapping
from dataclasses import dataclass
from enum import Enum
from typing import Any, Final, get_args

from pydantic import BaseModel

from pirate_bt.behaviours.base import NodeMixin
from pirate_bt.errors import InputError
from pirate_bt.treefile.params import PARAM_RE, SI_UNITS, ParamType
from pirate_bt.treefile.registry import Registry, default_registry

__all__ = [
    "BTCPP_FORMAT",
    "FROM_BTCPP",
    "TO_BTCPP",
    "NodeModel",
    "PortModel",
    "decode_value",
    "encode_value",
    "node_models",
]

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
_OWN_INSTEAD: Final = {"Timeout": ("timeout", "msec"), "Sleep": ("wait", "msec")}
"""BT.CPP nodes whose pirate_bt counterpart is its own node (see docs/interop.md): the
node to write instead, and BT.CPP's port of whole milliseconds."""


def own_instead(tag: str, attrs: dict[str, str]) -> str:
    """What to write for BT.CPP's ``tag`` (``Timeout``, ``Sleep``) in pirate_bt's own
    node, the milliseconds as a duration (``<timeout duration="500 ms">``); empty when
    ``tag`` has no such counterpart."""
    if tag not in _OWN_INSTEAD:
        return ""
    kind, port = _OWN_INSTEAD[tag]
    msec = attrs.get(port, "")
    duration = f"{msec} ms" if msec.isascii() and msec.isdigit() else "..."
    return (
        " (it reads the wall clock in whole milliseconds); write pirate_bt's own"
        f' <{kind} duration="{duration}">, which reads the run\'s clock (simulated or not)'
    )


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
        "SequenceStar",  # SequenceWithMemory, by its old name (still registered)
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
_MAX_JSON_DEPTH: Final = 32
"""The deepest nesting of a ``json:`` port value (a comparison list is three deep)."""


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
        models[name] = _class_model(name, cls)
    models["parallel"] = _PARALLEL_MODEL
    return models


_CLASS_MODELS: dict[tuple[str, int], tuple[type[NodeMixin], NodeModel]] = {}


def _class_model(name: str, cls: type[NodeMixin]) -> NodeModel:
    """One node type's model (a class's parameter model does not change: kept)."""
    kept = _CLASS_MODELS.get((name, id(cls)))
    if kept is not None and kept[0] is cls:
        return kept[1]
    doc = (cls.__doc__ or "").strip().splitlines()
    model = NodeModel(name, _category(cls), _ports(cls.Params), doc[0] if doc else "")
    _CLASS_MODELS[(name, id(cls))] = (cls, model)
    return model


PORT_NAME_RULE: Final = (
    "a port name starts with a letter A-Z or a-z and is not 'name' or 'ID'; one starting"
    " with '_' is BT.CPP's own, such as _while or _skipIf"
)
"""What BT.CPP takes for a port at a ``<SubTree>`` call (:func:`btcpp_port_name`)."""


def btcpp_port_name(name: str) -> bool:
    """Whether BT.CPP takes ``name`` for a port (its ``IsAllowedPortName``).

    A ``<SubTree>`` attribute named ``ID`` or ``name`` is the call's own, one whose
    first character is no ASCII letter is ignored by BT.CPP's parser, and ``_while``,
    ``_skipIf``, ``_onSuccess``... are its pre- and post-condition scripts; BT.CPP 4.9
    and later refuse a ``<SubTree>`` model's port of a reserved name.
    """
    first = name[:1]
    return first.isascii() and first.isalpha() and name not in ("name", "ID")


# -- values ----------------------------------------------------------------------------


def _xml_safe(text: str) -> bool:
    """``text`` holds only characters XML 1.0 can carry (no control characters but
    tab and line ends, no surrogates, no U+FFFE or U+FFFF)."""
    return all(
        c in "\t\n\r" or ("\x20" <= c <= "\ud7ff") or ("\ue000" <= c <= "\ufffd") or c > "\uffff"
        for c in text
    )


def _json(value: Any) -> str:
    text = json.dumps(value, ensure_ascii=False, separators=(",", ":"))
    if not _xml_safe(text):  # JSON's \uXXXX escapes say it in characters XML carries
        text = json.dumps(value, ensure_ascii=True, separators=(",", ":"))
    return "json:" + text


def _shown(text: str) -> str:
    """``text`` quoted for a message, cut short when it is long."""
    return repr(text) if len(text) <= 60 else repr(text[:57] + "...")


def _refuse_constant(name: str) -> Any:
    raise ValueError(f"{name} is not a JSON number")


def _unique_keys(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    """A JSON object whose keys are each written once: Python's reader keeps the last of
    two (``{"k": 1, "k": 2}`` read as ``{"k": 2}``), where a tree file refuses both."""
    out: dict[str, Any] = {}
    for key, value in pairs:
        if key in out:
            raise ValueError(f"duplicate key {_shown(key)} in an object")
        out[key] = value
    return out


def _finite(text: str) -> float:
    value = float(text)
    if not math.isfinite(value):
        raise ValueError(f"{_shown(text)} is not a finite number")
    return value


def _json_depth(value: Any) -> int:
    """How deep lists and mappings nest in ``value`` (iterative)."""
    deepest = 0
    stack = [(value, 1)]
    while stack:
        item, depth = stack.pop()
        if isinstance(item, dict | list):
            deepest = max(deepest, depth)
            stack.extend(
                (v, depth + 1) for v in (item.values() if isinstance(item, dict) else item)
            )
    return deepest


def _pointer(text: str) -> str | None:
    """The blackboard key ``text`` points to as BT.CPP reads it (its
    ``isBlackboardPointer``: ``{key}`` with any spaces around it), or None."""
    inner = text.strip(" ")
    if len(inner) >= 3 and inner[0] == "{" and inner[-1] == "}":
        return inner[1:-1]
    return None


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
        if (
            (value.startswith("{") and value.endswith("}"))
            or _pointer(value)
            or value.startswith("json:")
            or not _xml_safe(value)
        ):
            return _json(value)  # would read as a pointer or as JSON, or XML cannot carry it
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
            value = json.loads(
                text[5:],
                parse_constant=_refuse_constant,
                parse_float=_finite,
                object_pairs_hook=_unique_keys,
            )
        except json.JSONDecodeError as exc:
            raise ValueError(f"bad json: value: {exc.msg}") from None
        except RecursionError:
            raise ValueError(f"bad json: nested deeper than {_MAX_JSON_DEPTH} levels") from None
        except ValueError as exc:  # NaN, Infinity; a number too long for Python
            digits = _too_long(text[5:])
            said = f"a number of {digits} digits is too long" if digits else str(exc).split(";")[0]
            raise ValueError(f"bad json: value: {said}") from None
        if _json_depth(value) > _MAX_JSON_DEPTH:
            raise ValueError(f"bad json: nested deeper than {_MAX_JSON_DEPTH} levels")
        # "\ud800" alone: no character (the tree file could not hold it)
        half = re.search("[\ud800-\udfff]", json.dumps(value, ensure_ascii=False))
        if half is not None:
            raise ValueError(
                f"bad json: value: \\u{ord(half[0]):04x} is half a surrogate pair, not a character"
            )
        return value
    pointer = _pointer(text)
    if pointer is not None:
        name = port if pointer == "=" else pointer
        if not PARAM_RE.fullmatch("$" + name):  # '{café}': no $café names a parameter
            if _is_json(text):  # '{"k": 1}': JSON, which BT.CPP reads after json: only
                raise ValueError(
                    f"{_shown(text)} reads as a blackboard pointer: JSON needs the json:"
                    " prefix (json:{...})"
                )
            raise ValueError(
                f"blackboard pointer {_shown(text)}: pirate_bt parameters are identifiers"
                " of ASCII letters, digits and '_'"
            )
        return "$" + name
    if text.startswith("$"):
        return "$" + text
    if port_type in ("integer", "number"):
        return _number(text, port_type)
    if port_type == "boolean":
        if text in _TRUE:
            return True
        if text in _FALSE:
            return False
        raise ValueError(
            f"expected true or false, got {_shown(text)}"
            " (BT.CPP reads true, True, TRUE or 1, false, False, FALSE or 0)"
        )
    return text


# What BT.CPP's convertFromString reads (std::from_chars, base 10): an optional '-' and
# the digits, no '+', no spaces, no '_'; a number also '.5', '5.', '1e5', inf and nan.
# BT.CPP reads the longest such start of the text and drops the rest ('3abc' is 3).
# Before 4.9 a number was read with std::stod, which also takes '+1.5' and ' 1.5':
# what 4.9 reads is what every version reads.
_INTEGER_RE: Final = re.compile(r"-?[0-9]+")
_NUMBER_RE: Final = re.compile(
    r"-?(?:(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?|inf(?:inity)?|nan)", re.IGNORECASE
)
_TRUE: Final = frozenset({"true", "True", "TRUE", "1"})
_FALSE: Final = frozenset({"false", "False", "FALSE", "0"})


def _number(text: str, port_type: str) -> int | float:
    """An integer or number port's text, taken when BT.CPP reads all of it; refused
    otherwise, saying what BT.CPP does with it (refuses it, or reads only its start,
    which would run with another value than the text says). nan and inf are read, for
    the loader to refuse as every other file's."""
    integer = port_type == "integer"
    form = _INTEGER_RE if integer else _NUMBER_RE
    if text.isascii() and form.fullmatch(text):
        digits = _too_long(text) if integer else 0
        if digits:  # as the YAML loader says it: it is an integer, past what is read
            raise ValueError(f"a number of {digits} digits is too long")
        return int(text) if integer else float(text)
    words = "an integer" if integer else "a number"
    who = "BT.CPP" if integer else "BT.CPP 4.9 and later"  # 4.8 read a number with stod
    start = form.match(text)
    if text[:1].isspace():
        why = f"{who} reads no space before it"
    elif start is not None:
        why = f"{who} would read it as {_shown(start[0])}, dropping the rest; write {words} alone"
    elif text[:1] == "+":
        why = f"{who} reads no '+': write it without"
    else:
        why = f"{who} reads an optional '-' and the digits 0-9" + (
            "" if integer else ", a '.' and an exponent"
        )
    raise ValueError(f"expected {words}, got {_shown(text)}: {why}")


def _is_json(text: str) -> bool:
    try:
        json.loads(text, parse_constant=_refuse_constant)
    except (ValueError, RecursionError):
        return False
    return True


def _too_long(text: str) -> int:
    """The digits of the longest run of ASCII digits in ``text`` when it is longer than
    Python reads as an integer (``sys.get_int_max_str_digits()``), else 0."""
    longest = max((len(run) for run in re.findall("[0-9]+", text)), default=0)
    limit = sys.get_int_max_str_digits()
    return longest if limit and longest > limit else 0
