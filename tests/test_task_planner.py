"""Mission planning on the map: routes become PAB chains; misfits fail at their line."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from pirate_bt.errors import LocatedError
from pirate_bt.pipes import load_network
from pirate_bt.robot.description import RobotDescription
from pirate_bt.robot.loader import load_robot
from pirate_bt.task.planner import (
    MAP_OK_KEY,
    load_network_for,
    mission_tree_spec,
    plan_goal,
    plan_route,
    rear_lead_m,
    robot_length_m,
)
from pirate_bt.task.route import load_route, parse_route

REPO = Path(__file__).resolve().parent.parent
SHIPPED = sorted((REPO / "scenarios").glob("*.route"))


@pytest.fixture(scope="module")
def robot() -> RobotDescription:
    return load_robot()


def plan_text(text: str, network: str, robot: RobotDescription):  # type: ignore[no-untyped-def]
    return plan_route(parse_route(text, "t.route"), load_network(network), robot)


@pytest.mark.parametrize("path", SHIPPED, ids=[p.name for p in SHIPPED])
def test_shipped_routes_plan(path: Path, robot: RobotDescription) -> None:
    route = load_route(path)
    plan = plan_route(route, load_network_for(route, None), robot)
    assert plan.pabs
    for before, after in zip(plan.pabs, plan.pabs[1:], strict=False):
        assert after.start_m == pytest.approx(before.end_m)
    assert 0 < plan.end_m <= plan.path.length_m


def test_lab_route_is_a_full_inspection(robot: RobotDescription) -> None:
    route = load_route(REPO / "scenarios" / "lab.route")
    plan = plan_route(route, load_network_for(route, None), robot)
    bends = [p for p in plan.pabs if p.pab == "bend"]
    tees = [p for p in plan.pabs if p.pab == "t-joint"]
    assert [b.feature for b in bends] == ["bend-a", "bend-b", "bend-c", "bend-d", "bend-e"]
    assert [t.params["direction"] for t in tees] == ["straight", "straight"]
    # Rolls come from the map, in the simulator's convention (0 up, +90 right).
    rolls = [math.degrees(b.params["roll"]) for b in bends]
    assert rolls == pytest.approx([90, -90, 180, 0, 0])
    assert any(p.inspect for p in plan.pabs)
    # It ends at the top of the riser, the end of the main.
    assert plan.path.piece_at(plan.end_m).segment == "riser"
    assert plan.end_m == pytest.approx(plan.path.length_m - plan.contract.end_margin_m)
    assert plan.distance_m > 25


def test_auto_approach_and_robot_clears_the_bend(robot: RobotDescription) -> None:
    plan = plan_text("forward 1 m\nat the bend turn right\n", "bend-right", robot)
    assert [p.pab for p in plan.pabs] == ["straight", "straight", "bend"]
    bend_piece = next(p for p in plan.path.pieces if p.segment == "bend")
    approach = plan.pabs[1]
    assert approach.end_m == pytest.approx(bend_piece.start_m - plan.contract.approach_m)
    c = plan.contract
    assert plan.pabs[2].end_m == pytest.approx(
        bend_piece.start_m + rear_lead_m(robot) + c.follow_m + c.turn_overrun_m
    )
    assert plan.pabs[2].end_m > bend_piece.end_m + robot_length_m(robot)
    assert plan.features[0].segment == "bend" and plan.features[0].kind == "bend"


def test_tee_choice_changes_the_path(robot: RobotDescription) -> None:
    plan = plan_text("at the T-joint go left\nforward to the end\n", "t-joint", robot)
    assert dict(plan.choices) == {"tee": "branch"}
    assert plan.path.segments[-1] == "branch"
    assert plan.features[0].kind == "tee_turn"
    straight = plan_text("at the T-joint go straight\nforward 1 m\n", "t-joint", robot)
    assert dict(straight.choices) == {"tee": "straight"}


MISFITS = [
    ("bend-left", "forward 1 m\nat the bend turn up\n", 2, "turns left, not up"),
    ("bend-up", "forward 50 m\n", 1, "the bend 'bend' (up) starts"),
    ("straight", "forward 50 m\n", 1, "only 4.44 m of pipe are left"),
    ("straight", "at the bend turn up\n", 1, "no bend ahead"),
    ("t-joint", "at the bend turn up\n", 1, "the next feature is the T-joint 'tee'"),
    ("t-joint", "at the T-joint go right\n", 1, "branches left, not right"),
    ("t-joint", "forward to the end\n", 1, "write 'at the T-joint go straight'"),
    ("bend-up", "at the T-joint go left\n", 1, "the next feature is the bend"),
    ("bend-up", "at the bend turn up\nreturn to start\n", 2, "passes 'bend'"),
    ("straight", "back 1 m\n", 1, "back up at most 0.00 m"),
    ("lab", "go to service-9\n", 1, "no segment 'service-9'; did you mean"),
    ("lab", "go to bend-a\n", 1, "is a bend"),
    ("lab", "at the bend turn right\ngo to entry\n", 2, "not ahead of the robot"),
    # the bend lies beyond the distance: the approach margin is what does not fit
    (
        "lab",
        "forward 3.3 m\n",
        1,
        "starts 3.48 m ahead, and a straight stops 0.25 m before it (here at most 3.23 m)",
    ),
    ("lab", "forward 5 m\n", 1, "starts 3.48 m ahead, within 5 m;"),
]


@pytest.mark.parametrize(("network", "text", "line", "words"), MISFITS)
def test_route_that_does_not_fit_fails_at_its_line(
    network: str, text: str, line: int, words: str, robot: RobotDescription
) -> None:
    with pytest.raises(LocatedError) as info:
        plan_text(text, network, robot)
    assert info.value.location.line == line
    assert str(info.value).startswith(f"t.route:{line}:1: ")
    assert words in str(info.value)


def test_two_turns_too_close_say_how_much_pipe_passing_needs(
    tmp_path: Path, robot: RobotDescription
) -> None:
    # the message said "closer than the robot is long (0.52 m)" of two bends 0.60 m apart
    net = tmp_path / "r6.yaml"
    net.write_text(
        "schema_version: 1\nname: r6\ndiameter: 63 mm\nsegments:\n"
        "  - {id: level, type: straight, length: 1 m}\n"
        "  - {id: foot, type: bend, direction: up}\n"
        "  - {id: riser, type: straight, length: 0.6 m}\n"
        "  - {id: top, type: bend, direction: down}\n"
        "  - {id: upper, type: straight, length: 1.5 m}\n"
    )
    with pytest.raises(LocatedError) as info:
        plan_text("at the bend turn up\n", str(net), robot)
    message = str(info.value)
    assert "'foot' and 'top' are 0.60 m apart" in message
    need = float(message.split("needs ")[1].split(" m")[0])
    assert need > 0.6 and f"is {robot_length_m(robot):.2f} m long" in message


def test_goal_planning_takes_the_way_through_the_junctions(robot: RobotDescription) -> None:
    lab = load_network("lab")
    plan = plan_goal(lab, "service-2", robot)
    assert dict(plan.choices) == {"tee-1": "straight", "tee-2": "branch"}
    assert [p.feature for p in plan.pabs if p.feature] == ["bend-a", "tee-1", "bend-b", "tee-2"]
    goal = next(p for p in plan.path.pieces if p.segment == "service-2")
    assert goal.start_m < plan.end_m <= goal.end_m


def test_mission_tree_is_one_sequence_of_subtrees(tmp_path: Path, robot: RobotDescription) -> None:
    for name in ("straight", "bend", "t-joint"):
        (tmp_path / f"{name}.yaml").write_text("root: success\n")
    (tmp_path / "straight.yaml").write_text(
        "params: {distance: length, speed: velocity}\nroot: success\n"
    )
    route = load_route(REPO / "scenarios" / "lab.route")
    plan = plan_route(route, load_network_for(route, None), robot)
    spec = mission_tree_spec(plan, tmp_path, nominal_speed_mps=0.08)
    root = spec["root"]
    assert root["type"] == "eternal_guard"
    assert root["conditions"][0]["key"] == MAP_OK_KEY
    children = root["child"]["children"]
    assert len(children) == len(plan.pabs)
    assert children[0]["type"] == "sequence"  # an inspection: log + drive
    drive = children[0]["children"][1]
    assert drive["params"] == {"distance": 3.0, "speed": pytest.approx(0.04)}
    bend = next(c for c in children if c.get("params", {}).get("roll") is not None)
    assert bend["ref"].endswith("bend.yaml") and "(line 6)" in bend["name"]
    names = [c["name"] for c in children]
    assert len(set(names)) == len(names) and not any("/" in n for n in names)


@pytest.mark.parametrize("path", SHIPPED, ids=[p.name for p in SHIPPED])
def test_legs_leave_a_margin_before_every_feature(path: Path, robot: RobotDescription) -> None:
    # A few centimetres of drift must never drive the robot into a feature: every leg
    # ends at least min_margin_m before the next feature it does not pass itself (the
    # PAB that passes the feature senses the rest).
    route = load_route(path)
    plan = plan_route(route, load_network_for(route, None), robot)
    margin = plan.contract.min_margin_m
    for pab in plan.pabs:
        ahead = [
            f.start_m
            for f in plan.features
            if f.segment != pab.feature and f.start_m > pab.start_m + 1e-6
        ]
        if ahead:
            assert pab.end_m <= min(ahead) - margin + 1e-6, (pab.note, pab.end_m, min(ahead))


def test_straight_through_tee_needs_no_extra_leg(robot: RobotDescription) -> None:
    plan = plan_text("at the T-joint go straight\nforward 1 m\n", "t-joint", robot)
    assert [p.pab for p in plan.pabs] == ["straight", "t-joint", "straight"]
    tee = next(p for p in plan.path.pieces if p.segment == "tee")
    assert tee.opening_m is not None
    assert plan.pabs[1].end_m == pytest.approx(
        tee.opening_m + rear_lead_m(robot) + plan.contract.tee_exit_m
    )
