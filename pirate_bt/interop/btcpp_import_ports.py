"""BehaviorTree.CPP v4 XML import, a subtree's ports: the ``<input_port>`` elements of a
``<SubTree>`` model in ``<TreeNodesModel>`` read as the subtree's declared parameters
(name, type, default, example, choices, description), and a port's ``default`` or
``example`` read as a value. Used by :mod:`pirate_bt.interop.btcpp_import`.
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

__all__ = ["port_value", "subtree_ports"]


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
        kind = port.attrs.get("type", "string")
        if kind not in _PARAM_TYPES:
            raise port.error(
                f"port {_shown(name)}: type {_shown(kind)} is not a pirate_bt parameter type"
                f" ({', '.join(sorted(_PARAM_TYPES))})"
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
