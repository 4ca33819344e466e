"""Probe 12 of missions, navigations and surveys on steep pipes and wrong maps.

A robot put into a pipe steeper than ``motion.max_unclamped_slope`` slid before its
first clamp held, and the simulator counted it (*sliding: unclamped on a -15 deg
slope*, at 0.01 s). A tree run counted it from the link's opening and said so in its
``why``; a mission and a navigation counted from their own start, after it: they
claimed a plain success, with ``result.sim`` saying 1 violation and
``result.counters`` 0, and the belief 0.19 m behind the truth. Since 74fdbff the
robot is put in held, as an operator holds it on its tether until its first clamp
(docs/simulator.md, *Falling*): no slide, nothing to count, and a tree run, a
mission and a navigation all say a plain success with the belief on the truth.
"""

from __future__ import annotations

from pathlib import Path

import pytest

import pirate_bt

NOTE = "the robot did not stay safe"


@pytest.fixture
def steep_start(tmp_path: Path) -> Path:
    net = tmp_path / "slope15.yaml"
    net.write_text(
        "schema_version: 1\nname: slope15\ndiameter: 63 mm\nslope: -15 deg\n"
        "segments:\n  - {id: run, type: straight, length: 3 m}\n"
    )
    route = tmp_path / "slope15.route"
    route.write_text("network slope15.yaml\nforward 1 m\n")
    return route


def test_a_robot_put_in_on_a_slope_is_held_until_it_clamps_in_a_mission(
    steep_start: Path,
) -> None:
    tree = pirate_bt.simulate_tree(
        "straight", params={"distance": "1 m"}, network=steep_start.with_suffix(".yaml")
    )
    assert tree.succeeded and NOTE not in tree.why, tree.why
    assert tree.counters.violations == 0
    result = pirate_bt.simulate_mission(steep_start)
    assert result.status == "success" and result.exit_code == 0
    assert result.sim["violations"] == 0 and result.counters.violations == 0
    assert NOTE not in result.why, result.why


def test_a_robot_put_in_on_a_slope_is_held_until_it_clamps_in_a_navigation(
    steep_start: Path,
) -> None:
    result = pirate_bt.navigate(
        "route",
        sim=steep_start.with_suffix(".yaml"),
        map=steep_start.with_suffix(".yaml"),
        params={"route": str(steep_start)},
    )
    assert result.status == "success"
    assert result.counters.violations == 0
    assert NOTE not in result.why, result.why
