"""Draw a robot description: modules front to rear, their boards, motors and sensors.

Building the graph (:func:`robot_graph`) and writing it (:func:`write_diagram`)
are two functions, as in ``py_trees.display``.
"""

from __future__ import annotations

import html
import shutil
from pathlib import Path

from pirate_bt.robot.description import Half, RobotDescription
from pirate_bt.units import format_quantity

__all__ = ["board_table", "robot_graph", "write_diagram"]

_LEFT_BREAK = '<br align="left"/>'
_HALF_COLOUR = {Half.FRONT: "#dbeafe", Half.REAR: "#dcfce7", None: "#fef3c7"}


def board_table(robot: RobotDescription) -> list[tuple[str, ...]]:
    """Rows of (board, module, motor 0, motor 1, sensor 0, sensor 1), as in DOMAIN.md."""
    rows: list[tuple[str, ...]] = []
    for board in sorted(robot.boards, key=lambda b: b.id):
        motors = {m.slot: f"{m.name} ({m.function})" for m in board.motors}
        sensors = {s.slot: f"{s.name} ({s.kind})" for s in board.sensors}
        rows.append(
            (
                str(board.id),
                board.module,
                motors.get(0, "-"),
                motors.get(1, "-"),
                sensors.get(0, "-"),
                sensors.get(1, "-"),
            )
        )
    return rows


def robot_graph(robot: RobotDescription) -> str:
    """Graphviz ``dot`` source of the robot: one cluster per module, boards inside."""
    lines = [
        "digraph robot {",
        "  rankdir=LR; node [shape=plain, fontname=Helvetica, fontsize=10];",
        f'  label="{html.escape(robot.name)}"; labelloc=t; fontname=Helvetica;',
    ]
    for index, module in enumerate(robot.modules):
        rows = [
            f'<tr><td bgcolor="{_HALF_COLOUR[module.half]}"><b>{html.escape(module.name)}</b>'
            f"<br/>{module.role}, {format_quantity(module.length, 'length')}</td></tr>"
        ]
        for board in sorted(robot.boards, key=lambda b: b.id):
            if board.module != module.name:
                continue
            parts = [f"board {board.id}"]
            parts += [f"M{m.slot} {html.escape(m.name)}" for m in board.motors]
            parts += [f"S{s.slot} {html.escape(s.name)}" for s in board.sensors]
            cell = _LEFT_BREAK.join(parts)
            rows.append(f'<tr><td align="left">{cell}</td></tr>')
        table = f'<<table border="1" cellborder="0" cellspacing="0">{"".join(rows)}</table>>'
        lines.append(f"  m{index} [label={table}];")
    for index in range(len(robot.modules) - 1):
        lines.append(f"  m{index} -> m{index + 1} [arrowhead=none, penwidth=3];")
    lines.append("}")
    return "\n".join(lines) + "\n"


def write_diagram(source: str, out: Path) -> Path:
    """Write ``source`` to ``out`` (``.dot``, ``.svg`` or ``.png`` by suffix).

    The ``.dot`` file is always written beside the picture, so nothing is lost
    when Graphviz is missing.

    Returns:
        The path of the ``.dot`` file, or of the picture when one was drawn.

    Raises:
        FileNotFoundError: ``dot`` is not installed and a picture was asked for
            (the ``.dot`` file has been written all the same).
        ValueError: an unsupported suffix.
    """
    suffix = out.suffix.lower()
    if suffix not in (".dot", ".svg", ".png"):
        raise ValueError(f"cannot draw to {out.name!r}: use .dot, .svg or .png")
    out.parent.mkdir(parents=True, exist_ok=True)
    dot_path = out if suffix == ".dot" else out.with_suffix(".dot")
    tmp = dot_path.with_name(dot_path.name + ".tmp")
    tmp.write_text(source, encoding="utf-8")
    tmp.replace(dot_path)
    if suffix == ".dot":
        return dot_path
    if shutil.which("dot") is None:
        raise FileNotFoundError(
            f"Graphviz 'dot' is not installed, so {out} was not drawn; {dot_path} was written"
            " (install it with: apt-get install graphviz)"
        )
    import graphviz

    picture = graphviz.Source(source).pipe(format=suffix[1:])
    tmp_out = out.with_name(out.name + ".tmp")
    tmp_out.write_bytes(picture)
    tmp_out.replace(out)
    return out
