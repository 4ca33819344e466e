"""Straight through a tee, counted from the opening's near edge (``overshoot_key``, ``less_key``).

A drive ``until: front_opening`` stops once a front joint has swung past every
wall-contact angle: in a 51 mm pipe 30 mm past the opening's near edge, in a 80 mm pipe
a few millimetres. ``tee-straight.yaml`` drove its released front half 160 mm across
from there, so in narrow pipes, or on a slow link, bend III reached the opening before
the front half clamped: in a riser the robot slid (24 of 72 crossings of a probe over
51-100 mm, level and risers up and down, perfect and 30 ms links, on 2026-11-29). The
search now writes how far past the edge it stopped and the drive across takes it off.
"""

from __future__ import annotations

import logging
import re
from collections.abc import Iterator
from pathlib import Path

import py_trees
import pytest
from test_pabs_backwards import TREES, Session, first_feature, tee_network

import pirate_bt
from pirate_bt.errors import InputError
from pirate_bt.pipes import PieceKind
from pirate_bt.robot import load_robot
from pirate_bt.robot.description import Role

ROBOT = load_robot()
BEND_1_M = next(
    sum(x.length for x in ROBOT.modules[:i]) + m.length / 2
    for i, m in enumerate(ROBOT.modules)
    if m.role is Role.BEND
)
"""Bend I's centre behind the front tip: the first joint over an opening."""


@pytest.fixture(autouse=True)
def quiet(caplog: pytest.LogCaptureFixture) -> Iterator[None]:
    caplog.set_level(logging.ERROR)
    py_trees.blackboard.Blackboard.clear()
    yield


FIND_EDGE = f"""\
name: find-edge
blackboard:
  past: {{type: number, default: 0.0}}
  travelled: {{type: number, default: 0.0}}
root:
  type: sequence
  name: find
  children:
    - {{type: subtree, name: hold, ref: {TREES / "lib" / "hold.yaml"}}}
    - {{type: drive, name: find opening, velocity: 80 mm/s, until: front_opening,
        max_distance: 1 m, overshoot_key: past, travelled_key: travelled}}
"""


@pytest.mark.parametrize(
    ("diameter", "least_mm"),
    [("51 mm", 20.0), ("63 mm", 10.0), ("80 mm", 0.0)],
)
def test_the_search_says_how_far_past_the_edge_it_stopped(
    tmp_path: Path, diameter: str, least_mm: float
) -> None:
    tree = tmp_path / "find-edge.yaml"
    tree.write_text(FIND_EDGE)
    session = Session(tee_network(tmp_path, "left", diameter), start_m=1.5, seed=1)
    try:
        run = session.run(str(tree), {})
        tee = first_feature(session.network, PieceKind.TEE)
    finally:
        session.close()
    assert run.result.succeeded, run.reason
    past = py_trees.blackboard.Blackboard.storage["/past"]
    travelled = py_trees.blackboard.Blackboard.storage["/travelled"]
    assert tee.opening_m is not None
    edge = tee.opening_m - tee.diameter_start_m / 2
    truly_past = run.truth.front_m - BEND_1_M - edge
    # The narrower the pipe, the further the joint swings before it is past every
    # contact angle, and the further the drive goes on.
    assert past * 1000 >= least_mm
    assert past < travelled
    # within a few millimetres of the truth (the tick on which the swing began, the
    # odometry's ramp against the wheels')
    assert abs(truly_past - past) <= 0.005, (truly_past, past)


# -- the crossings that slid ----------------------------------------------------------


def _riser_tee(tmp: Path, diameter: int, way: str) -> Path:
    name = f"riser-tee-{diameter}-{way}"
    (tmp / f"{name}.yaml").write_text(
        f"schema_version: 1\nname: {name}\ndiameter: {diameter} mm\nsegments:\n"
        "  - {id: level, type: straight, length: 1.2 m}\n"
        f"  - {{id: foot, type: bend, direction: {way}}}\n"
        "  - {id: riser, type: straight, length: 1.0 m}\n"
        "  - {id: tee, type: tee, branch: {direction: left, segments:"
        " [{id: branch, type: straight, length: 0.8 m}]}}\n"
        "  - {id: after, type: straight, length: 0.8 m}\n"
    )
    route = tmp / f"{name}.route"
    route.write_text(
        f"network {name}.yaml\nat the bend turn {way}\nat the T-joint go straight\n"
        "forward to the end\n"
    )
    return route


@pytest.mark.parametrize(
    ("diameter", "way", "faults"),
    [
        (51, "up", None),  # slid once, and the mission succeeded with the note
        (51, "down", None),  # slid: the supervisor's hold ended the mission
        (63, "up", "delay=30ms"),  # four slides on a slow link
        (80, "down", "delay=30ms"),
    ],
)
def test_straight_through_a_tee_in_a_riser_does_not_slide(
    tmp_path: Path, diameter: int, way: str, faults: str | None
) -> None:
    result = pirate_bt.simulate_mission(_riser_tee(tmp_path, diameter, way), faults=faults)
    assert result.succeeded, result.why
    assert result.counters.violations == 0, result.counters.violation_kinds
    assert "simulator counted" not in result.why
    assert result.tee_fallbacks == 0


# -- the parameters --------------------------------------------------------------------


@pytest.mark.parametrize(
    ("drive", "key", "problem"),
    [
        (
            "{type: drive, name: d, velocity: 80 mm/s, distance: 1 m, overshoot_key: past}",
            "overshoot_key",
            "drive: overshoot_key: only with until: front_opening or rear_opening, or"
            " stop_at_feature",
        ),
        (
            "{type: drive, name: d, velocity: 80 mm/s, until: front_opening, less_key: past}",
            "less_key",
            "drive: less_key: only with until: distance",
        ),
    ],
)
def test_a_key_where_it_means_nothing_is_refused_where_it_stands(
    tmp_path: Path, drive: str, key: str, problem: str
) -> None:
    column = len("    - ") + drive.index(key) + 1  # the key, in the tree's line 8
    tree = tmp_path / "t.yaml"
    tree.write_text(
        "name: t\nblackboard:\n  past: {type: number, default: 0.0}\nroot:\n"
        f"  type: sequence\n  name: s\n  children:\n    - {drive}\n"
    )
    with pytest.raises(InputError, match=re.escape(f"{tree}:8:{column}: {problem}")):
        pirate_bt.load_tree(tree, robot=ROBOT)


def test_less_key_takes_its_metres_off_the_distance_and_nothing_left_is_done() -> None:
    tree = {
        "name": "t",
        "blackboard": {"past": {"type": "number", "default": 0.3}},
        "root": {
            "type": "sequence",
            "name": "s",
            "children": [
                # a drive with no half clamped fails (the wheels would turn on the spot)
                {"type": "clamp", "half": "rear", "torque": "0.7 N*m"},
                {
                    "type": "drive",
                    "name": "d1",
                    "velocity": "80 mm/s",
                    "distance": "0.5 m",
                    "less_key": "past",
                    "travelled_key": "went",
                },
                {
                    "type": "drive",
                    "name": "d2",
                    "velocity": "80 mm/s",
                    "distance": "0.2 m",
                    "less_key": "past",
                },
            ],
        },
    }
    tree["blackboard"]["went"] = {"type": "number", "default": 0.0}  # type: ignore[index]
    result = pirate_bt.simulate_tree(tree)
    assert result.succeeded, result.why
    went = py_trees.blackboard.Blackboard.storage["/went"]
    assert 0.2 <= went < 0.21  # 0.5 m less 0.3 m
    nodes = {n.path.rsplit("/", 1)[-1]: n for n in result.coverage or ()}
    assert nodes["d2"].successes == 1  # 0.2 m less 0.3 m: nothing to drive


def test_less_key_holding_no_number_fails_the_drive_naming_the_key() -> None:
    tree = {
        "name": "t",
        "blackboard": {"past": {"type": "string", "default": "far"}},
        "root": {
            "type": "drive",
            "name": "d",
            "velocity": "80 mm/s",
            "distance": "0.5 m",
            "less_key": "past",
        },
    }
    result = pirate_bt.simulate_tree(tree)
    assert not result.succeeded
    assert "blackboard 'past' holds 'far', not metres" in result.why
