"""Probe 14 of the protective layer: hostile trees that validate, at run time.

Trees that load cleanly but try to make the robot do what it should not: drive with
no half holding it, command the same motors from two branches of a parallel, end a
running drive from a decorator, feed a primitive a distance or a sign from the
blackboard that no file could have written. Each test asserts on what a user sees:
the run's ``why`` (its first cause), the supervisor's refusals, and the simulator's
truth at the end (nothing moved that should not have, nothing left moving).
"""

from __future__ import annotations

import math
from typing import Any

import py_trees
import pytest

import pirate_bt
from pirate_bt.errors import ValidationFailed
from pirate_bt.safety import Drive, Reason, Rotate
from pirate_bt.safety.verdict import Outcome

HOLD: list[dict[str, Any]] = [
    {"type": "clamp", "name": "clamp rear", "half": "rear", "torque": "0.7 N*m"},
    {"type": "move_front_clear", "name": "clear"},
    {"type": "clamp", "name": "clamp front", "half": "front", "torque": "0.7 N*m"},
]


def _tree(*children: Any, blackboard: dict[str, Any] | None = None) -> dict[str, Any]:
    tree: dict[str, Any] = {
        "name": "hostile",
        "root": {"type": "sequence", "children": list(children)},
    }
    if blackboard:
        tree["blackboard"] = blackboard
    return tree


def _par(*children: Any, policy: str = "all") -> dict[str, Any]:
    return {"type": "parallel", "name": "both", "policy": policy, "children": list(children)}


def _drive(name: str = "drive", velocity: str = "80 mm/s", **more: Any) -> dict[str, Any]:
    return {"type": "drive", "name": name, "velocity": velocity, "distance": "0.3 m", **more}


def _run(tree: dict[str, Any], network: str = "straight", **options: Any) -> tuple[Any, Any, float]:
    """(result, connection, metres the robot really moved), the connection still open."""
    robot = pirate_bt.connect(network)
    sim = robot.simulator
    assert sim is not None
    start = sim.truth().front_m
    result = robot.run(tree, max_time=options.pop("max_time", "30 s"), **options)
    return result, robot, sim.truth().front_m - start


def _refused(robot: Any) -> list[Any]:
    return [v for v in robot.supervisor.verdicts if v.outcome is Outcome.REFUSE]


# -- a drive that no half holds the robot for ------------------------------------------


def test_a_drive_with_no_half_clamped_fails_not_counted_as_travelled() -> None:
    # put in free on the level, the tree drives 0.3 m: the wheels turn, the robot does
    # not move (the simulator's traction rule), and the odometry counted 0.3 m: success
    result, robot, moved = _run(_tree(_drive()))
    with robot:
        assert result.status == "failure"
        assert result.why.startswith("no half holds the robot (front unclamped, rear"), result.why
        assert "the wheels would turn on the spot" in result.why
        assert result.failing_node == "hostile/drive"
        # nothing was sent: the supervisor lets it go on the level (nothing is damaged)
        assert not any(isinstance(v.command, Drive) for v in robot.supervisor.verdicts)
        assert moved == 0.0


def test_a_drive_with_one_half_clamped_still_passes() -> None:
    tree = _tree({"type": "clamp", "half": "rear", "torque": "0.7 N*m"}, _drive())
    result, robot, moved = _run(tree)
    with robot:
        assert result.status == "success", result.why
        assert moved == pytest.approx(0.3, abs=0.02)


# -- two primitives on the same motors at once -----------------------------------------


@pytest.mark.parametrize("other", ["-80 mm/s", "40 mm/s"])
def test_two_drives_at_once_from_a_parallel_are_refused(other: str) -> None:
    # both succeeded, each counting 0.3 m, while the robot stayed where it was (one
    # forwards, one back) or went 0.3 m (two speeds): a success that was no one's drive
    tree = _tree(*HOLD, _par(_drive("a"), _drive("b", other)))
    result, robot, moved = _run(tree)
    with robot:
        assert result.status == "failure"
        assert "motor_conflict" in result.why, result.why
        assert "hostile/both/a" in result.why  # the node that holds the motors
        refused = _refused(robot)
        assert refused and refused[0].reason is Reason.MOTOR_CONFLICT
        assert refused[0].node_name == "hostile/both/b"
        assert abs(moved) < 0.05
        assert robot.simulator.truth().velocity_mps == 0.0


def test_two_rotations_at_once_are_refused_not_fought_to_a_timeout() -> None:
    # the rear half released, two rotates to +30 and -30 deg: the joint went back and
    # forth until one timed out after 10 s
    tree = _tree(
        *HOLD,
        {"type": "unclamp", "half": "rear"},
        _par(
            {"type": "rotate", "name": "left", "angle": "30 deg"},
            {"type": "rotate", "name": "right", "angle": "-30 deg"},
        ),
    )
    result, robot, _ = _run(tree)
    with robot:
        assert result.status == "failure"
        assert "motor_conflict" in result.why, result.why
        assert result.sim_time_s < 8.0
        refused = _refused(robot)
        assert refused and isinstance(refused[0].command, Rotate)


def test_a_clamp_and_a_release_of_the_same_half_at_once_are_refused() -> None:
    tree = _tree(
        *HOLD,
        _par(
            {"type": "clamp", "name": "grip", "half": "front", "torque": "0.7 N*m"},
            {"type": "unclamp", "name": "let go", "half": "front"},
        ),
    )
    result, robot, _ = _run(tree)
    with robot:
        assert result.status == "failure"
        assert "motor_conflict" in result.why, result.why


def test_one_primitive_after_another_on_the_same_motors_passes() -> None:
    # the rule is about two at once: a drive after a drive, a clamp after a release
    tree = _tree(
        *HOLD,
        _drive("there"),
        _drive("back", reverse=True),
        {"type": "unclamp", "half": "front"},
        {"type": "clamp", "half": "front", "torque": "0.7 N*m"},
    )
    result, robot, moved = _run(tree)
    with robot:
        assert result.status == "success", result.why
        assert abs(moved) < 0.02


# -- decorators that end a running drive -----------------------------------------------


def test_a_timeout_that_ends_a_running_drive_is_the_why() -> None:
    tree = _tree(*HOLD, {"type": "timeout", "name": "limit", "duration": "1 s", "child": _drive()})
    result, robot, moved = _run(tree)
    with robot:
        assert result.status == "failure"
        # it said "tree failed after 76 ticks"
        assert result.why == "timed out after 1 s: drive was still running", result.why
        assert result.failing_node == "hostile/limit"
        assert 0.0 < moved < 0.1
        assert robot.simulator.truth().velocity_mps == 0.0


@pytest.mark.parametrize(
    ("guard", "said"),
    [
        (
            {
                "type": "while",
                "condition": {"state": "drive_velocity", "op": "<", "value": "50 mm/s"},
            },
            "not (drive_velocity < 50 mm/s): it is 0.06",
        ),
        (
            {
                "type": "failure_if",
                "condition": {"state": "half.rear", "op": "==", "value": "clamped"},
            },
            "half.rear == clamped",
        ),
        ({"type": "running_is_failure"}, "running is failure"),
    ],
)
def test_a_decorator_that_fails_a_running_drive_is_the_why(
    guard: dict[str, Any], said: str
) -> None:
    # each said "tree failed after 58 ticks": the decorator's own reason was lost
    tree = _tree(*HOLD, {**guard, "name": "guard", "child": _drive()})
    result, robot, _ = _run(tree)
    with robot:
        assert result.status == "failure"
        assert result.why.startswith(said), result.why
        assert result.failing_node == "hostile/guard"
        assert robot.simulator.truth().velocity_mps == 0.0


# -- what a primitive reads from the blackboard ----------------------------------------


@pytest.mark.parametrize(
    ("value", "said"),
    [(-5.0, "-5.0"), (math.nan, "nan"), (math.inf, "inf")],
)
def test_a_distance_from_the_blackboard_that_is_no_distance_fails_the_drive(
    value: float, said: str
) -> None:
    # -5 m succeeded at once without moving; nan and inf drove until the time limit
    tree = _tree(
        *HOLD,
        {"type": "drive", "velocity": "80 mm/s", "distance_key": "far"},
        blackboard={"far": {"type": "length", "external": True}},
    )
    py_trees.blackboard.Blackboard.storage["/far"] = value
    try:
        result, robot, moved = _run(tree)
    finally:
        py_trees.blackboard.Blackboard.storage.pop("/far", None)
    with robot:
        assert result.status == "failure"
        assert result.why.startswith(f"blackboard 'far' holds {said},"), result.why
        assert result.sim_time_s < 10.0
        assert moved == 0.0


def test_a_sign_that_is_a_boolean_is_no_sign() -> None:
    tree = _tree(
        *HOLD,
        {"type": "unclamp", "half": "front"},
        {"type": "set_blackboard", "key": "sign", "value": True},
        {"type": "bend", "module": "front", "angle": "40 deg", "sign_from": "sign"},
        blackboard={"sign": {"type": "number"}},
    )
    result, robot, _ = _run(tree)
    with robot:
        assert result.status == "failure"
        assert result.why == "blackboard 'sign' is True, not +1 or -1", result.why


# -- a refused command asked again and again -------------------------------------------


def test_a_node_refused_again_and_again_between_passes_ends_in_the_safe_state() -> None:
    # a selector without memory tries the hold and a refused rotation each tick, and
    # falls back to a drive: the hold's clamps pass between the refusals, so "5 refused
    # commands in a row" never came; 166 refusals in 60 s, to the time limit
    tree = {
        "name": "hostile",
        "root": {
            "type": "selector",
            "name": "loop",
            "children": [
                {
                    "type": "sequence",
                    "name": "try",
                    "children": [*HOLD, {"type": "rotate", "name": "turn", "angle": "30 deg"}],
                },
                _drive("instead", distance="3 m"),
            ],
        },
    }
    result, robot, _ = _run(tree, max_time="60 s")
    with robot:
        assert result.status == "failure"
        assert result.stop == "failure", result.why
        assert result.why.startswith(
            "5 refused commands of loop/try/turn (rotate_needs_one_clamped: rotation"
        ), result.why
        assert len(_refused(robot)) == 5
        assert result.sim_time_s < 20.0
        assert robot.simulator.truth().velocity_mps == 0.0


TWO_DRIVES = """\
name: two drives
root:
  type: sequence
  children:
    - {type: clamp, name: cr, half: rear, torque: 0.7 N*m}
    - type: parallel
      children:
        - {type: drive, name: fwd, velocity: 80 mm/s, distance: 0.3 m}
        - {type: drive, name: back, velocity: -80 mm/s, distance: 0.3 m}
"""


def test_the_command_line_names_the_conflict_in_one_line_and_the_trace_the_refusal(
    tmp_path: Any, capsys: pytest.CaptureFixture[str]
) -> None:
    from pirate_bt.cli import main

    tree = tmp_path / "two.yaml"
    tree.write_text(TWO_DRIVES)
    trace = tmp_path / "two.jsonl"
    code = main(["run", str(tree), "--sim", "scenarios/straight.yaml", "-q", "--trace", str(trace)])
    assert code == 1
    last = capsys.readouterr().err.strip().splitlines()[-1]
    assert last.startswith(
        "pirate-bt: two drives: FAILURE - refused drive(-80 mm/s): motor_conflict: the drive"
        " motors are commanded by two drives/parallel/fwd, still running"
    ), last
    records = pirate_bt.read_trace(trace)
    refused = [c for r in records.ticks for c in r.commands if c["verdict"] == "refuse"]
    assert [c["reason"] for c in refused] == ["motor_conflict"]
    assert refused[0]["command"] == "drive(-80 mm/s)"


@pytest.mark.parametrize(
    ("params", "said"),
    [
        ({"v": "100.0001 mm/s"}, "velocity: 100.0001 mm/s is above bend_1_drive's limit 100 mm/s"),
        ({"t": "0.80001 N*m"}, "torque: 0.80001 N*m is above the bend joints' limit 0.8 N*m"),
        ({"a": "110.001 deg"}, "angle: 110.001° is beyond bend_1's range [-110.0°, 110.0°]"),
        ({"r": "175.0004 deg"}, "angle: 175.000400° is beyond the rotation range"),
    ],
)
def test_a_value_just_past_a_limit_is_not_shown_as_the_limit(
    params: dict[str, str], said: str
) -> None:
    # it said "100 mm/s is above ... limit 100 mm/s", "110.0° is beyond [..., 110.0°]"
    tree = {
        "name": "limits",
        "params": {
            "v": {"type": "velocity", "default": "80 mm/s"},
            "t": {"type": "torque", "default": "0.7 N*m"},
            "a": {"type": "angle", "default": "10 deg"},
            "r": {"type": "angle", "default": "10 deg"},
        },
        "root": {
            "type": "sequence",
            "children": [
                {"type": "clamp", "half": "rear", "torque": "$t"},
                {"type": "bend", "module": "bend_1", "angle": "$a"},
                {"type": "rotate", "angle": "$r"},
                {"type": "drive", "velocity": "$v", "distance": "0.1 m"},
            ],
        },
    }
    with pytest.raises(ValidationFailed) as caught:
        pirate_bt.load_tree(tree, params=params)
    assert said in str(caught.value), str(caught.value)


# -- in a vertical riser ---------------------------------------------------------------


def test_in_a_riser_a_parallel_that_releases_both_halves_leaves_one_holding() -> None:
    from pirate_bt.pipes import network_from_data

    riser = network_from_data(
        {
            "name": "shaft",
            "diameter": "63 mm",
            "slope": "90 deg",
            "segments": [{"id": "shaft", "type": "straight", "length": "4 m"}],
        }
    )
    release = _par(
        {"type": "unclamp", "name": "front", "half": "front"},
        {"type": "unclamp", "name": "rear", "half": "rear"},
    )
    with pirate_bt.connect(riser) as robot:
        sim = robot.simulator
        assert sim is not None
        result = robot.run(_tree(*HOLD, release), max_time="30 s")
        slid = dict(sim.counters().violations)  # put in free, it slid until the clamp
        assert result.status == "failure"
        assert result.why.startswith(
            "refused unclamp(rear): steep_pipe_unclamped: releasing the rear half would leave"
            " no half clamped in a steep pipe"
        ), result.why
        # the front half's release passed (the rear held), the rear's was refused
        truth = sim.truth()
        assert truth.halves["rear"].clamped and not truth.sliding
        robot.clock.advance(3.0)
        sim.advance_to(robot.clock.now())
        assert sim.truth().halves["rear"].clamped
        assert dict(sim.counters().violations) == slid
