"""The eighth probe of the planner's API: trees given in Python.

Each test is a bug the probe found; it failed before its fix.
"""

from __future__ import annotations

import pytest

import pirate_bt
from pirate_bt.errors import ValidationFailed

HARD = {"name": "t", "root": {"type": "clamp", "name": "c", "half": "front", "torque": "50 N*m"}}


def _line_of(marker: str) -> int:
    with open(__file__, encoding="utf-8") as f:
        return next(n for n, line in enumerate(f, 1) if marker in line)


def test_a_tree_given_as_a_mapping_is_refused_at_the_planners_line() -> None:
    # was "<dict>:1:1: clamp: torque: ...": nowhere in the planner's code, although
    # parameters and nodes built in Python are placed at the planner's line
    with pytest.raises(ValidationFailed) as caught:
        pirate_bt.simulate_tree(HARD)  # the call: simulate_tree
    where = f"tests/test_probe8_api_trees.py:{_line_of('# the call: simulate_tree')}:1"
    assert str(caught.value) == (
        f"{where}: clamp: torque: 50 N*m is above the bend joints' limit 0.8 N*m"
    )
    with pytest.raises(ValidationFailed) as caught:
        pirate_bt.load_tree({"name": "t", "root": {"type": "wiat"}})  # the call: load_tree
    line = _line_of("# the call: load_tree")
    assert str(caught.value).startswith(f"tests/test_probe8_api_trees.py:{line}:1: ")
    with pirate_bt.connect("sim:straight") as robot, pytest.raises(ValidationFailed) as caught:
        robot.run(HARD)  # the call: run
    line = _line_of("# the call: run")
    assert str(caught.value).startswith(f"tests/test_probe8_api_trees.py:{line}:1: clamp: ")
