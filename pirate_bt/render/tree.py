"""Draw a behaviour tree with Graphviz, optionally coloured by status at one tick.

Building the graph (:func:`tree_graph`, returns ``dot`` source) and writing it
(:func:`render_tree`, which uses :func:`write_diagram`) are two functions, as in
``py_trees.display``. Node kinds are told apart by shape, as in py_trees' own
drawings, so a diagram printed in black and white still reads:

========== ==================== ======================================
kind       shape                examples
========== ==================== ======================================
composite  box (sequence),      Sequence, Selector, Parallel
           octagon (selector),
           parallelogram
decorator  ellipse              Retry, Inverter
guard      house, bold border   Timeout, link-healthy and clamped guards
leaf       rounded box          clamp, drive, bend, rotate, conditions
========== ==================== ======================================

Without statuses, kinds are also filled in soft colours; with statuses (from a
trace), the fill is the status: green SUCCESS, red FAILURE, amber RUNNING,
white not ticked. Each node's parameters are listed under its name, and the
Graphviz node id is the trace's path id (``0.1.2``), which SVG output keeps as
the ``id`` of the node's group.
"""

from __future__ import annotations

import html
import json
from collections.abc import Mapping
from pathlib import Path

import py_trees

from pirate_bt.robot.diagram import write_diagram
from pirate_bt.trace.structure import NodeInfo, TreeStructure, tree_structure

__all__ = ["KIND_STYLE", "STATUS_FILL", "render_tree", "tree_graph", "write_diagram"]

#: kind -> Graphviz node attributes.
KIND_STYLE: Mapping[str, Mapping[str, str]] = {
    "composite": {"shape": "box", "fillcolor": "#fed7aa"},
    "decorator": {"shape": "ellipse", "fillcolor": "#e9d5ff"},
    "guard": {"shape": "house", "fillcolor": "#fecaca", "penwidth": "2"},
    "leaf": {"shape": "box", "style": "rounded,filled", "fillcolor": "#e5e7eb"},
}
_COMPOSITE_SHAPE = {"Selector": "octagon", "Parallel": "parallelogram"}

#: status code -> fill colour.
STATUS_FILL: Mapping[str, str] = {
    "S": "#86efac",
    "F": "#fca5a5",
    "R": "#fcd34d",
    "I": "#ffffff",
}
_STATUS_WORD = {"S": "SUCCESS", "F": "FAILURE", "R": "RUNNING", "I": "not ticked"}
_MAX_PARAM_CHARS = 40


def _param_text(value: object) -> str:
    if isinstance(value, float):
        text = f"{value:.4g}"
    elif isinstance(value, str):
        text = value
    else:
        text = json.dumps(value, separators=(",", ":"))
    if len(text) > _MAX_PARAM_CHARS:
        text = text[: _MAX_PARAM_CHARS - 1] + "…"
    return text


def _label(node: NodeInfo, status: str | None, feedback: str) -> str:
    rows = [f"<b>{html.escape(node.name)}</b>"]
    if node.type and node.type != node.name:
        rows.append(f'<font point-size="8">{html.escape(node.type)}</font>')
    for key, value in node.params.items():
        if value is None:
            continue
        rows.append(
            f'<font point-size="8">{html.escape(str(key))}: '
            f"{html.escape(_param_text(value))}</font>"
        )
    if status is not None and status != "I":
        word = _STATUS_WORD[status]
        text = f"{word}: {feedback}" if feedback else word
        if len(text) > _MAX_PARAM_CHARS:
            text = text[: _MAX_PARAM_CHARS - 1] + "…"
        rows.append(f'<font point-size="8"><i>{html.escape(text)}</i></font>')
    return "<" + "<br/>".join(rows) + ">"


def _attrs(attrs: Mapping[str, str]) -> str:
    out = []
    for key, value in attrs.items():
        if value.startswith("<") and value.endswith(">"):
            out.append(f"{key}={value}")
        else:
            out.append(f'{key}="{value}"')
    return ", ".join(out)


def tree_graph(
    tree: TreeStructure | py_trees.trees.BehaviourTree | py_trees.behaviour.Behaviour,
    status: Mapping[str, str] | None = None,
    feedback: Mapping[str, str] | None = None,
    title: str | None = None,
) -> str:
    """Graphviz ``dot`` source of a tree.

    Args:
        tree: A tree structure (e.g. from a trace header), a ``BehaviourTree``
            or a root behaviour.
        status: Status code (``S``/``F``/``R``/``I``) by node id, to colour by
            status; ``None`` colours by kind.
        feedback: Feedback message by node id, shown with the status.
        title: A caption (for example ``tick 42 at 4.200 s``).

    Returns:
        The ``dot`` source.
    """
    structure = tree if isinstance(tree, TreeStructure) else tree_structure(tree)
    feedback = feedback or {}
    caption = structure.name if title is None else f"{structure.name}: {title}"
    lines = [
        "digraph tree {",
        "  graph [rankdir=TB, ordering=out, nodesep=0.25, ranksep=0.45,"
        f' fontname=Helvetica, labelloc=t, label="{html.escape(caption)}"];',
        '  node [fontname=Helvetica, fontsize=10, style=filled, margin="0.12,0.04"];',
        "  edge [arrowsize=0.6];",
    ]
    for node in structure:
        attrs = dict(KIND_STYLE.get(node.kind, KIND_STYLE["leaf"]))
        if node.kind == "composite":
            attrs["shape"] = _COMPOSITE_SHAPE.get(node.type, attrs["shape"])
        code = None if status is None else status.get(node.id, "I")
        if code is not None:
            attrs["fillcolor"] = STATUS_FILL.get(code, STATUS_FILL["I"])
            attrs["tooltip"] = f"{node.id} {_STATUS_WORD.get(code, code)}"
        else:
            attrs["tooltip"] = f"{node.id} {node.kind}"
        attrs["id"] = node.id
        attrs["label"] = _label(node, code, feedback.get(node.id, ""))
        lines.append(f'  "{node.id}" [{_attrs(attrs)}];')
    for node in structure:
        for child in node.children:
            lines.append(f'  "{node.id}" -> "{child}";')
    lines.append("}")
    return "\n".join(lines) + "\n"


def render_tree(
    tree: TreeStructure | py_trees.trees.BehaviourTree | py_trees.behaviour.Behaviour,
    out: str | Path,
    status: Mapping[str, str] | None = None,
    feedback: Mapping[str, str] | None = None,
    title: str | None = None,
) -> Path:
    """Draw a tree to ``out`` (``.dot``, ``.svg`` or ``.png`` by suffix).

    Returns:
        The path written (the ``.dot`` file if Graphviz was not needed).

    Raises:
        FileNotFoundError: Graphviz ``dot`` is missing; the ``.dot`` file was
            written beside ``out`` all the same.
        ValueError: an unsupported suffix.
    """
    return write_diagram(tree_graph(tree, status, feedback, title), Path(out))
