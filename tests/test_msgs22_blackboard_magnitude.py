"""A quantity written in a tree file's ``set_blackboard``, ``check_blackboard`` or a
guard's comparison (``skip_if``) was not bounded: ``value: 1e300 m, unit: length``
validated, where every other quantity of a tree file is refused beyond
``units.MAGNITUDE_LIMITS``. Now refused alike, at the node's place."""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt import load_tree
from pirate_bt.errors import ValidationFailed

BOARD = "blackboard:\n  d: {type: number, external: true}\n"
SAID = "is out of range: a length is at most 1e+06 m (either sign)"
NODES = {
    "set": "{type: set_blackboard, key: d, value: VALUE, unit: length}",
    "check": "{type: check_blackboard, key: d, op: '<', value: VALUE, unit: length}",
    "guard": (
        "{type: skip_if, condition: {blackboard: d, op: '<', value: VALUE, unit: length},"
        " child: {type: wait, duration: 1 s}}"
    ),
}


@pytest.mark.parametrize("node", sorted(NODES))
@pytest.mark.parametrize("value", ["1e300 m", "-2000 km"])
def test_an_absurd_quantity_in_a_blackboard_node_is_refused_at_its_place(
    tmp_path: Path, node: str, value: str
) -> None:
    path = tmp_path / "t.yaml"
    path.write_text(
        "name: t\n" + BOARD + "root:\n  type: sequence\n  children:\n"
        "    - {type: wait, duration: 1 s}\n"
        f"    - {NODES[node].replace('VALUE', repr(value))}\n",
        encoding="utf-8",
    )
    with pytest.raises(ValidationFailed) as caught:
        load_tree(path)
    said = str(caught.value)
    assert f"{path}:8:" in said, said
    assert f"{value!r} {SAID}" in said, said


@pytest.mark.parametrize("node", sorted(NODES))
def test_a_long_but_possible_quantity_is_taken(tmp_path: Path, node: str) -> None:
    path = tmp_path / "t.yaml"
    path.write_text(
        f"name: t\n{BOARD}root: {NODES[node].replace('VALUE', '1000 km')}\n", encoding="utf-8"
    )
    load_tree(path)
