"""The value types compare by value: a network by its spec, so plans and mission
results that hold one compare equal when they are.

``pirate_bt.load_network("lab") == pirate_bt.load_network("lab")`` was False (no
``__eq__``), two ``plan_route`` of one route compared unequal, and a pickled
``MissionResult`` was unequal to its original (its network, and its py_trees tree,
which a pickle leaves out).
"""

from __future__ import annotations

import pickle

import pytest

import pirate_bt
from pirate_bt.pipes import Network


def test_two_loads_of_a_network_are_equal_and_another_is_not() -> None:
    lab = pirate_bt.load_network("lab")
    assert lab == pirate_bt.load_network("lab")
    assert lab == Network(lab.spec, "<elsewhere>")  # the same pipe, wherever it came from
    assert lab == pickle.loads(pickle.dumps(lab))
    assert lab != pirate_bt.load_network("straight")
    assert lab != "lab"
    with pytest.raises(TypeError, match="unhashable"):
        hash(lab)  # its spec holds lists: no value that cannot change


def test_two_plans_of_one_route_are_equal() -> None:
    first = pirate_bt.plan_route("scenarios/bend-right.route")
    assert first == pirate_bt.plan_route("scenarios/bend-right.route")
    assert first != pirate_bt.plan_route("scenarios/bend-left.route")


def test_a_pickled_mission_result_equals_its_original() -> None:
    result = pirate_bt.simulate_mission("scenarios/straight.route")
    assert result.succeeded, result.why
    again = pickle.loads(pickle.dumps(result))
    assert again == result
    assert again.tree is None and result.tree is not None  # not compared
