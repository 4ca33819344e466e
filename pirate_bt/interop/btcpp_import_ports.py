"""BehaviorTree.CPP v4 XML import, a subtree's ports: the ``<input_port>`` elements of a
``<SubTree>`` model in ``<TreeNodesModel>`` read as the subtree's declared parameters
(name, type, default, example, choices, description), and a port's ``default`` or
``example`` read as a value, a node's port text (``=``) and a tree's ``_blackboard``,
and the counts of BT.CPP's own nodes.
Used by :mod:`pirate_bt.interop.btcpp_import`.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from pirate_bt.interop.btcpp_models import (
    _PARAM_TYPES,
    PORT_NAME_RULE,
    _shown,
    btcpp_port_name,
    decode_value,
)
from pirate_bt.interop.btcpp_xml import XmlElement
from pirate_bt.treefile.params import PARAM_RE

__all__ = [
    "CPP_TYPES",
    "has_reference",
    "literal",
    "no_json",
    "own_key",
    "port_value",
    "subtree_ports",
    "tree_blackboard",
]

_INTEGERS = (
    "int", "unsigned", "unsigned int", "short", "unsigned short", "long", "unsigned long",
    "long long", "unsigned long long", "int8_t", "int16_t", "int32_t", "int64_t", "uint8_t",
    "uint16_t", "uint32_t", "uint64_t", "size_t", "std::size_t",
)  # fmt: skip
CPP_TYPES: dict[str, str] = {
    **dict.fromkeys(_INTEGERS, "integer"),
    **dict.fromkeys(("double", "float"), "number"),
    "bool": "boolean",
    **dict.fromkeys(("std::string", "string", "BT::StringView", "std::string_view"), "string"),
}
"""The C++ type names a BT.CPP model writes (``BT::demangle``'s, as BT.CPP's own
``writeTreeNodesModelXML`` and Groot2 do) read as the pirate_bt parameter type they hold.
BT.CPP itself reads no type of a ``<SubTree>`` model's port (its values are text)."""


def subtree_ports(
    tree_id: str,
    model: XmlElement,
    place: Callable[[dict[str, Any], XmlElement], None] | None = None,
) -> dict[str, Any]:
    """The parameters the ``<SubTree ID=tree_id>`` model declares; ``place``, if given,
    records each declaration (a mapping of the output) as coming from its
    ``<input_port>``.

    Raises:
        LocatedError: a port that cannot be a pirate_bt parameter, at its element.
    """
    out: dict[str, Any] = {}
    for port in model.children:
        if port.tag != "input_port":
            raise port.error(
                f"<{port.tag}>: a pirate_bt subtree takes input ports (its parameters) only"
            )
        name = port.attrs.get("name", "")
        if not name.isidentifier():
            raise port.error(f"port name {_shown(name)} must be an identifier")
        if not btcpp_port_name(name):  # export would refuse it; no call can give it
            raise port.error(
                f"port name {_shown(name)}: BehaviorTree.CPP takes no port of this name"
                f" ({PORT_NAME_RULE}); rename it"
            )
        if name in out:
            raise port.error(
                f"a second input_port {_shown(name)} in <SubTree ID={_shown(tree_id)}>"
            )
        written = port.attrs.get("type", "string")
        kind = CPP_TYPES.get(" ".join(written.split()), written)
        if kind not in _PARAM_TYPES:
            raise port.error(
                f"port {_shown(name)}: type {_shown(written)} is not a pirate_bt parameter type"
                f" ({', '.join(sorted(_PARAM_TYPES))}) nor a C++ type of one (int, double,"
                " bool, std::string...)"
            )
        decl: dict[str, Any] = {"type": kind}
        if place is not None:
            place(decl, port)
        try:
            for key in ("default", "example"):
                if key in port.attrs:
                    decl[key] = port_value(port.attrs[key], kind, name, key)
            if "choices" in port.attrs:
                decl["choices"] = _choices(port.attrs["choices"])
        except ValueError as exc:
            raise port.error(f"port {_shown(name)}: {exc}") from None
        description = port.attrs.get("description") or port.text.strip()
        if description:
            decl["description"] = description
        out[name] = decl
    return out


def _choices(text: str) -> Any:
    """A port's ``choices``: ``a;b;c``, as a node model writes them (and BT.CPP a list
    port's text), or ``json:["a", "b"]``, as the export writes a subtree's (a choice
    holding ``;``). The loader checks what the list holds."""
    value = decode_value(text, "json") if text.startswith("json:") else text.split(";")
    if not isinstance(value, list) or not text or value == []:
        raise ValueError(
            f'choices {_shown(text)}: a list of one or more, written a;b;c or json:["a", "b"]'
        )
    return value


def port_value(text: str, kind: str, name: str, key: str) -> Any:
    """A ``default`` or ``example`` of a subtree's port; a blackboard pointer (``{d}``)
    is refused in the XML's words (the loader's would advise ``$$d``, which the XML
    reads as the text ``$$d``).

    Raises:
        ValueError: the text does not fit the port's type, or it is a pointer.
    """
    value = decode_value(text, kind, name)
    if isinstance(value, str) and PARAM_RE.match(value):
        raise ValueError(
            f"{key} {_shown(text)} is a blackboard pointer; a parameter's {key} is a value,"
            " not another parameter"
        )
    return value


def tree_blackboard(tree: XmlElement) -> dict[str, Any]:
    """A tree's ``_blackboard``: its keys' declarations, JSON after ``json:``."""
    text = tree.attrs.get("_blackboard")
    if text is None:
        return {}
    form = """_blackboard='json:{"k": {"type": "number"}}'"""
    if not text.startswith("json:"):
        what = "JSON needs" if text.lstrip().startswith("{") else "the declarations take"
        raise tree.error(f"_blackboard: {what} the json: prefix, as in {form}")
    try:
        board = decode_value(text, "json")
    except ValueError as exc:
        raise tree.error(f"_blackboard: {exc}") from None
    if not isinstance(board, dict):
        raise tree.error(f"_blackboard: a JSON object of key -> declaration, as in {form}")
    return board


def own_key(text: str) -> str:
    """A node's port text; ``=`` is BT.CPP's pointer to the port's own key, as ``{=}``."""
    return "{=}" if text == "=" else text


def has_reference(value: Any) -> bool:
    """``value`` (a node's ports, read) names a parameter (``$name``) somewhere."""
    if isinstance(value, str):
        return PARAM_RE.match(value) is not None
    if isinstance(value, dict):
        return any(has_reference(v) for v in value.values())
    if isinstance(value, list):
        return any(has_reference(v) for v in value)
    return False


def no_json(element: XmlElement, key: str, text: str) -> None:
    """A count of BT.CPP's own nodes is an int port, read by ``convertFromString<int>``
    (``std::from_chars``), which takes no ``json:`` (``json:true`` is no count to it)."""
    if text.startswith("json:"):
        raise element.error(
            f"{key}={_shown(text)}: BT.CPP reads <{element.tag}>'s {key} as an int, digits"
            f' only, not json: ({key}="1")'
        )


def literal(value: Any) -> Any:
    """``value`` (a node's parameters as the tree file holds them) with each text the
    file escapes (``$$x``, written for the XML's ``$x``) read as a run reads it."""
    if isinstance(value, str):
        return value[1:] if value.startswith("$$") else value
    if isinstance(value, dict):
        return {k: literal(v) for k, v in value.items()}
    if isinstance(value, list):
        return [literal(v) for v in value]
    return value
