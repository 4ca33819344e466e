"""The labels and attributes of a tree diagram's nodes (split from
:mod:`pirate_bt.render.tree`, which lays the diagram out): each node's name, type,
parameters, status at a tick or coverage, as an HTML-like Graphviz label a hostile
tree's text cannot break, and its fill colours.
"""

from __future__ import annotations

import functools
import html
import json
import re
from collections.abc import Mapping
from typing import Any, Final, get_args

from pirate_bt import units
from pirate_bt.trace.coverage import NodeCoverage
from pirate_bt.trace.structure import NodeInfo

__all__ = [
    "COVERAGE_BANDS",
    "MAX_NAME_CHARS",
    "STATUS_FILL",
    "STATUS_WORD",
    "attrs_text",
    "band",
    "cut",
    "label",
    "quoted",
]


#: status code -> fill colour.
STATUS_FILL: Mapping[str, str] = {
    "S": "#86efac",
    "F": "#fca5a5",
    "R": "#fcd34d",
    "I": "#ffffff",
}
STATUS_WORD = {"S": "SUCCESS", "F": "FAILURE", "R": "RUNNING", "I": "not ticked"}

#: (fewest ticks, fill colour, words) per band of a node's tick count, for coverage.
COVERAGE_BANDS: tuple[tuple[int, str, str], ...] = (
    (0, "#ffffff", "never ran"),
    (1, "#dbeafe", "1-9 ticks"),
    (10, "#93c5fd", "10-99 ticks"),
    (100, "#3b82f6", "100-999 ticks"),
    (1000, "#1d4ed8", "1000+ ticks"),
)
_MAX_PARAM_CHARS = 40
MAX_NAME_CHARS = 80
"""The most characters of a node's name or type, or of the tree's, a diagram shows: a
hostile tree's 200,000-character name made a label Graphviz refuses (an HTML-like
string of more than 16,384 characters), and no picture."""


_UNWRITABLE = re.compile("[\x00-\x08\x0a-\x1f\x7f-\x9f\ud800-\udfff\ufffe\uffff]")
"""Characters an HTML-like Graphviz label (read as XML) cannot carry, the C1 controls,
and a line break (``\\n``, ``\\r``), which it would draw as nothing."""


def _html(text: str) -> str:
    """``text`` for an HTML-like label: escaped, each control character (a hostile
    tree's or trace's: ``"\\x07"`` in a log message) shown as its escape, which Graphviz
    would otherwise refuse, failing the whole drawing, a line break too (Graphviz drew
    ``"x\\ny"`` as ``xy``), and a backslash doubled: Graphviz reads ``\\N``, ``\\G``
    and ``\\E`` in an HTML-like label as well (a message ``C:\\New`` was drawn with the
    node's id in place of ``\\N``)."""
    shown_text = _UNWRITABLE.sub(lambda m: repr(m[0])[1:-1], text)
    return html.escape(shown_text).replace("\\", "\\\\")


def quoted(text: str) -> str:
    """``text`` inside a quoted DOT string: as :func:`_html`, whose backslash is doubled
    there too (a name ending in ``\\`` would end the string; ``\\G`` would become the
    graph's id)."""
    return _html(text)


def _param_text(value: object) -> str:
    if isinstance(value, float):
        text = f"{value:.4g}"
    elif isinstance(value, str):
        text = value
    else:
        text = json.dumps(value, separators=(",", ":"))
    return cut(text, _MAX_PARAM_CHARS)


_SI_UNIT_OF: Final = {
    id(get_args(quantity)[1]): unit
    for quantity, unit in (
        (units.Length, "m"),
        (units.Duration, "s"),
        (units.Angle, "rad"),
        (units.Velocity, "m/s"),
        (units.AngularVelocity, "rad/s"),
        (units.Acceleration, "m/s^2"),
        (units.Force, "N"),
        (units.Torque, "N*m"),
        (units.Frequency, "Hz"),
        (units.Current, "A"),
    )
}
"""Each quantity type's validator (one object a type, shared by every field of it) ->
the SI unit a node holds its value in."""


def _unit_of(metadata: Any, annotation: Any) -> str | None:
    """The SI unit of a parameter given by ``metadata`` and ``annotation`` (its
    quantity type, also inside ``Duration | None``), if it is a quantity."""
    for item in (*metadata, *getattr(annotation, "__metadata__", ())):
        if id(item) in _SI_UNIT_OF:
            return _SI_UNIT_OF[id(item)]
    for arg in get_args(annotation):
        found = _unit_of((), arg)
        if found is not None:
            return found
    return None


@functools.cache
def si_units(node_type: str) -> Mapping[str, str]:
    """The SI unit of each quantity parameter of the node class ``node_type`` names (a
    registered node type's class, as a diagram names it: ``Wait``); none for another."""
    from pirate_bt.treefile.registry import default_registry

    registry = default_registry()
    for name in registry.names():
        cls = registry.get(name)
        if cls.__name__ == node_type:
            fields = getattr(getattr(cls, "Params", None), "model_fields", {})
            found = {k: _unit_of(f.metadata, f.annotation) for k, f in fields.items()}
            return {k: unit for k, unit in found.items() if unit is not None}
    return {}


def cut(text: str, limit: int) -> str:
    """``text`` cut to ``limit`` characters, its end shown as ``…``."""
    return text if len(text) <= limit else text[: limit - 1] + "…"


def band(ticks: int) -> tuple[int, str, str]:
    return [band for band in COVERAGE_BANDS if ticks >= band[0]][-1]


def _coverage_row(seen: NodeCoverage) -> str:
    parts = [f"ticks {seen.ticks}", f"ok {seen.successes}", f"fail {seen.failures}"]
    parts += [f"{name} {n}" for name, n in (("halts", seen.halts), ("skips", seen.skips)) if n]
    return f'<font point-size="8"><i>{_html(" · ".join(parts))}</i></font>'


def label(
    node: NodeInfo, status: str | None, feedback: str, seen: NodeCoverage | None = None
) -> str:
    name = cut(node.name, MAX_NAME_CHARS)
    rows = [f"<b>{_html(name) or ' '}</b>"]  # <b></b> is no label to Graphviz
    if node.type and node.type != node.name:
        rows.append(f'<font point-size="8">{_html(cut(node.type, MAX_NAME_CHARS))}</font>')
    si = si_units(node.type) if node.params else {}
    for key, value in node.params.items():
        if value is None:
            continue
        text = _param_text(value)
        if key in si and isinstance(value, (int, float)) and not isinstance(value, bool):
            text = f"{text} {si[key]}"  # the value as the node holds it: in SI (40 deg: rad)
        rows.append(f'<font point-size="8">{_html(str(key))}: {_html(text)}</font>')
    if status is not None and status != "I":
        word = STATUS_WORD[status]
        text = f"{word}: {feedback}" if feedback else word
        if len(text) > _MAX_PARAM_CHARS:
            text = text[: _MAX_PARAM_CHARS - 1] + "…"
        rows.append(f'<font point-size="8"><i>{_html(text)}</i></font>')
    if seen is not None:
        rows.append(_coverage_row(seen))
    return "<" + "<br/>".join(rows) + ">"


def attrs_text(attrs: Mapping[str, str]) -> str:
    """DOT attributes; the label is HTML-like (made by :func:`_label`), every other value
    a quoted string (an id read from a trace may look like ``<...>`` too)."""
    out = []
    for key, value in attrs.items():
        if key == "label":
            out.append(f"{key}={value}")
        else:
            out.append(f'{key}="{quoted(value)}"')
    return ", ".join(out)
