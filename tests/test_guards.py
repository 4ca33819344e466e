"""Guard nodes: conditions and the skip_if / failure_if / while pre-conditions."""

from __future__ import annotations

import math

import py_trees
import pytest
from py_trees.common import Status

from pirate_bt.behaviours.guards import (
    Comparison,
    failure_if,
    is_clamped,
    link_healthy,
    mode_is,
    skip_if,
    state_fresh,
    while_,
)
from pirate_bt.clock import SimClock
from pirate_bt.errors import ValidationFailed
from pirate_bt.robot import Half, load_robot
from pirate_bt.safety import Mode, Supervisor
from pirate_bt.safety.testing import FakePort
from pirate_bt.treefile.loader import load_tree

ROBOT = load_robot()


@pytest.fixture(autouse=True)
def clean_blackboard() -> None:
    py_trees.blackboard.Blackboard.clear()


@pytest.fixture
def clock() -> SimClock:
    return SimClock(5.0)


@pytest.fixture
def port(clock: SimClock) -> FakePort:
    return FakePort(ROBOT, clock)


@pytest.fixture
def sup(port: FakePort, clock: SimClock) -> Supervisor:
    return Supervisor(port, clock)


def tick(node: py_trees.behaviour.Behaviour) -> Status:
    node.tick_once()
    status: Status = node.status
    return status


class Counter(py_trees.behaviour.Behaviour):
    """Runs ``ticks`` times, then succeeds; counts ticks and halts."""

    def __init__(self, ticks: int = 2) -> None:
        super().__init__("counter")
        self.ticks = ticks
        self.count = 0
        self.halted = 0

    def initialise(self) -> None:
        self.count = 0

    def update(self) -> Status:
        self.count += 1
        return Status.SUCCESS if self.count >= self.ticks else Status.RUNNING

    def terminate(self, new_status: Status) -> None:
        if new_status == Status.INVALID:
            self.halted += 1


def test_is_clamped(sup: Supervisor, port: FakePort) -> None:
    node = is_clamped(sup, Half.REAR)
    assert tick(node) == Status.FAILURE
    port.clamp_half(Half.REAR)
    assert tick(node) == Status.SUCCESS


def test_link_healthy(sup: Supervisor, port: FakePort) -> None:
    node = link_healthy(sup)
    assert tick(node) == Status.SUCCESS
    port.connected = False
    assert tick(node) == Status.FAILURE


def test_state_fresh(sup: Supervisor, port: FakePort, clock: SimClock) -> None:
    node = state_fresh(sup)
    assert tick(node) == Status.SUCCESS
    port.freeze("bend_1_spring")
    clock.advance(1.0)
    assert tick(node) == Status.FAILURE
    assert tick(state_fresh(sup, ["bend_1_angle"])) == Status.SUCCESS


def test_mode_is(sup: Supervisor) -> None:
    node = mode_is(sup, Mode.MANUAL)
    assert tick(node) == Status.FAILURE
    sup.set_mode(Mode.MANUAL)
    assert tick(node) == Status.SUCCESS


def test_conditions_fail_without_a_robot() -> None:
    assert tick(is_clamped(None, Half.FRONT)) == Status.FAILURE


def test_skip_if_state_comparison(sup: Supervisor, port: FakePort) -> None:
    child = Counter(1)
    guard = skip_if(child, {"state": "imu.pitch", "op": ">", "value": math.radians(10)}, sup)
    port.set_pitch(math.radians(20))
    assert tick(guard) == Status.SUCCESS and child.count == 0
    port.set_pitch(0.0)
    assert tick(guard) == Status.SUCCESS and child.count == 1


def test_failure_if_blackboard_comparison() -> None:
    child = Counter(1)
    guard = failure_if(child, {"blackboard": "/roll", "op": "==", "value": 90, "unit": None})
    assert tick(guard) == Status.FAILURE  # unset key: a guard never guesses
    py_trees.blackboard.Blackboard.set("/roll", 90)
    assert tick(guard) == Status.FAILURE and child.count == 0
    py_trees.blackboard.Blackboard.set("/roll", 0)
    assert tick(guard) == Status.SUCCESS and child.count == 1


def test_skip_if_is_not_rechecked_while_running() -> None:
    child = Counter(3)
    py_trees.blackboard.Blackboard.set("/skip", False)
    guard = skip_if(child, {"blackboard": "skip", "value": True})
    assert tick(guard) == Status.RUNNING
    py_trees.blackboard.Blackboard.set("/skip", True)
    assert tick(guard) == Status.RUNNING
    assert tick(guard) == Status.SUCCESS and child.count == 3


def test_while_halts_a_running_child_and_fails(sup: Supervisor, port: FakePort) -> None:
    port.clamp_half(Half.REAR)
    child = Counter(5)
    guard = while_(child, {"state": "half.rear", "op": "==", "value": "clamped"}, sup)
    assert tick(guard) == Status.RUNNING
    assert tick(guard) == Status.RUNNING
    port.free_half(Half.REAR)
    assert tick(guard) == Status.FAILURE
    assert child.halted == 1 and child.status == Status.INVALID


def test_while_skips_when_false_before_start(sup: Supervisor) -> None:
    child = Counter(1)
    guard = while_(child, [{"state": "mode", "value": "manual"}], sup)
    assert tick(guard) == Status.SUCCESS and child.count == 0


def test_all_comparisons_must_hold(sup: Supervisor, port: FakePort) -> None:
    child = Counter(1)
    condition = [
        {"state": "half.front", "value": "unclamped"},
        {"state": "link.healthy", "value": True},
        {"state": "rotation", "op": "<", "value": 0.1},
    ]
    assert tick(failure_if(child, condition, sup)) == Status.FAILURE
    port.set(rotation_angle=0.5)
    assert tick(failure_if(child, condition, sup)) == Status.SUCCESS


@pytest.mark.parametrize(
    "bad",
    [
        {"state": "os.system", "value": 1},
        {"state": "imu.pitch", "value": "10 mm"},
        {"state": "half.front", "value": "gripping"},
        {"value": 1},
        {"state": "imu.pitch", "blackboard": "x", "value": 1},
        {"state": "mode", "value": "turbo"},
    ],
)
def test_bad_comparisons_are_refused(bad: dict[str, object]) -> None:
    with pytest.raises(ValueError):
        Comparison.model_validate(bad)


def test_guards_load_from_yaml(sup: Supervisor, port: FakePort, clock: SimClock) -> None:
    tree = {
        "name": "guarded",
        "blackboard": {"go": {"type": "boolean", "default": True}},
        "root": {
            "type": "sequence",
            "children": [
                {"type": "link_healthy"},
                {"type": "state_fresh"},
                {"type": "mode_is", "mode": "autonomous"},
                {
                    "type": "skip_if",
                    "condition": {"state": "imu.pitch", "op": ">", "value": "10 deg"},
                    "child": {"type": "is_clamped", "half": "rear"},
                },
                {
                    "type": "while",
                    "condition": [{"blackboard": "go", "value": True}],
                    "child": {"type": "success"},
                },
                {
                    "type": "failure_if",
                    "condition": {"state": "half.front", "op": "==", "value": "clamped"},
                    "child": {"type": "success"},
                },
            ],
        },
    }
    loaded = load_tree(tree, robot=ROBOT, clock=clock, supervisor=sup, units_required=True)
    assert loaded.needs_robot
    loaded.write_blackboard_defaults()
    bt = loaded.behaviour_tree()
    port.clamp_half(Half.REAR)
    bt.tick()
    assert bt.root.status == Status.SUCCESS
    port.set_pitch(math.radians(20))
    port.free_half(Half.REAR)
    bt.tick()
    assert bt.root.status == Status.SUCCESS  # the is_clamped check was skipped


def test_yaml_guard_with_unknown_state_value_is_located() -> None:
    tree = {
        "name": "bad",
        "root": {
            "type": "skip_if",
            "condition": {"state": "__import__", "value": 1},
            "child": {"type": "success"},
        },
    }
    with pytest.raises(ValidationFailed, match="unknown state value"):
        load_tree(tree, robot=ROBOT)
