"""A robot whose halves must bend further than 40° to count as steered into a turn.

``motion.steer_angle`` is the joint angle at which the simulator (and the robot)
lets a half enter a turn. The bundled PAB trees steer 40°, enough for the reference
robot's 30°. A robot that needs 50° used to fail every bend as a map disagreement
("blocked: every drive draws stall current after 0.000 m"): the trees steered 40°
whatever the robot. Now a mission and a navigation step pass the robot's own angle
(and a margin) to the PAB trees that declare ``steer``, ``bend.yaml`` and
``t-joint.yaml`` forward it, and a steering bend below the robot's angle is refused
when the tree loads, naming the node's file, line and column.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from pirate_bt import simulate_mission, simulate_tree
from pirate_bt.errors import ValidationFailed
from pirate_bt.robot import load_robot
from pirate_bt.task.planner import load_network_for, plan_route
from pirate_bt.task.route import load_route
from pirate_bt.task.tree import STEER_MARGIN_RAD, mission_tree_spec

REPO = Path(__file__).resolve().parent.parent
STEER = "  steer_angle: 30 deg\n"


@pytest.fixture
def wide(tmp_path: Path) -> Path:
    text = (REPO / "hardware" / "pirate.yaml").read_text(encoding="utf-8")
    assert text.count(STEER) == 1
    path = tmp_path / "wide.yaml"
    path.write_text(text.replace(STEER, "  steer_angle: 50 deg\n"), encoding="utf-8")
    return path


def test_a_mission_through_a_bend_steers_as_far_as_the_robot_needs(wide: Path) -> None:
    result = simulate_mission(REPO / "scenarios" / "bend-right.route", robot=wide)
    assert result.succeeded, result.why


def test_a_mission_through_a_tee_branch_steers_as_far_as_the_robot_needs(wide: Path) -> None:
    result = simulate_mission(REPO / "scenarios" / "t-joint.route", robot=wide)
    assert result.succeeded, result.why


def test_the_bend_pab_alone_refuses_to_steer_less_than_the_robot_needs(wide: Path) -> None:
    with pytest.raises(ValidationFailed) as caught:
        simulate_tree("bend", network="bend-right", params={"roll": "90 deg"}, robot=wide)
    text = str(caught.value)
    assert "bend.yaml:" in text and "turn.yaml:" in text  # where given, where used
    assert "40.0° steers less than the robot's motion.steer_angle (50.0°)" in text
    assert "steer parameter" in text


def test_the_bend_pab_alone_steers_as_far_as_it_is_told(wide: Path) -> None:
    result = simulate_tree(
        "bend", network="bend-right", params={"roll": "90 deg", "steer": "60 deg"}, robot=wide
    )
    assert result.succeeded, result.why


def test_the_reference_robot_gets_the_trees_own_steer() -> None:
    robot = load_robot()
    route = load_route(REPO / "scenarios" / "lab.route")
    plan = plan_route(route, load_network_for(route, None), robot)
    spec = mission_tree_spec(plan, None, robot.motion.nominal_speed, robot.motion.steer_angle)
    passed = [c.get("params", {}) for c in spec["root"]["child"]["children"]]
    assert not [p for p in passed if "steer" in p]  # 40° is enough for 30°: as before
    wide = robot.model_copy(
        update={"motion": robot.motion.model_copy(update={"steer_angle": math.radians(50)})}
    )
    spec = mission_tree_spec(plan, None, robot.motion.nominal_speed, wide.motion.steer_angle)
    steers = {
        p["steer"]
        for c in spec["root"]["child"]["children"]
        if "steer" in (p := c.get("params", {}))
    }
    assert steers == {math.radians(50) + STEER_MARGIN_RAD}
