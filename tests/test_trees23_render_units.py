"""A diagram shows each quantity parameter with its unit (docs/observability.md,
Diagrams).

A node holds a quantity in SI, and the diagram listed the bare number: ``angle: 40
deg`` was drawn ``angle: 0.6981``, ``velocity: 50 mm/s`` ``velocity: 0.05``, ``torque:
0.7 N*m`` ``torque: 0.7``, a figure a reader cannot take for anything.
"""

from __future__ import annotations

from pathlib import Path

from pirate_bt.cli import main
from pirate_bt.render import tree_graph

_TREE = """\
name: t
root:
  type: sequence
  children:
    - {type: bend, module: front, angle: 40 deg}
    - {type: drive, velocity: 50 mm/s, distance: 20 cm, timeout: 2 min}
    - {type: clamp, half: rear, torque: 0.7 N*m}
    - {type: wait, duration: 250 ms}
    - {type: retry, attempts: 2, child: success}
"""


def test_each_quantity_is_drawn_with_its_si_unit(tmp_path: Path) -> None:
    tree = tmp_path / "t.yaml"
    tree.write_text(_TREE, encoding="utf-8")
    source = tree_graph(str(tree))
    for row in (
        "angle: 0.6981 rad",
        "velocity: 0.05 m/s",
        "distance: 0.2 m",
        "timeout: 120 s",
        "torque: 0.7 N*m",
        "duration: 0.25 s",
    ):
        assert f'<font point-size="8">{row}</font>' in source, row
    # a count, a choice and a flag have no unit
    assert '<font point-size="8">module: front</font>' in source
    assert '<font point-size="8">reverse: false</font>' in source
    assert '<font point-size="8">num_failures: 2</font>' in source


def test_the_dot_file_the_command_writes_has_the_units(tmp_path: Path) -> None:
    tree = tmp_path / "t.yaml"
    tree.write_text(_TREE, encoding="utf-8")
    out = tmp_path / "t.dot"
    assert main(["render", str(tree), "-o", str(out)]) == 0
    assert "angle: 0.6981 rad" in out.read_text(encoding="utf-8")
