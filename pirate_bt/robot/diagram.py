"""Draw a robot description: modules front to rear, their boards, motors and sensors.

Building the graph (:func:`robot_graph`) and writing it
(:func:`pirate_bt.render.files.write_diagram`, shared with the tree diagrams) are two
functions, as in ``py_trees.display``.
"""

from __future__ import annotations

import html

from pirate_bt.robot.description import Half, RobotDescription
from pirate_bt.units import format_quantity

__all__ = ["board_table", "robot_graph"]

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
