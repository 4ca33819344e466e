"""Nodes built in Python get the checks and the messages of nodes in YAML files.

``Clamp.build(...)`` / ``Clamp.from_params(...)`` validate the parameters with the
class's model (numbers SI, text with units parsed) and against the robot's limits,
and report each problem at the caller's file and line; ``load_tree(params=...)``
called from Python locates a bad parameter at the caller too, while the commands
keep ``--param``.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import py_trees
import pytest
from py_trees.common import Status

from pirate_bt.behaviours.base import BuildContext
from pirate_bt.behaviours.basic import Retry, Scripted, Timeout, Wait
from pirate_bt.behaviours.primitives import Clamp, ClampParams
from pirate_bt.cli import main
from pirate_bt.clock import SimClock
from pirate_bt.errors import LocatedError, SourceLocation, ValidationFailed
from pirate_bt.robot import load_robot
from pirate_bt.robot.description import Half
from pirate_bt.treefile import load_tree

HERE = Path(__file__).resolve()


def _next_line() -> int:
    """The line after the caller's."""
    return sys._getframe(1).f_lineno + 1


@pytest.fixture(scope="module")
def ctx() -> BuildContext:
    return BuildContext(robot=load_robot(), clock=SimClock())


def _only(exc: pytest.ExceptionInfo[ValidationFailed]) -> LocatedError:
    assert len(exc.value.errors) == 1, str(exc.value)
    return exc.value.errors[0]


def _yaml_messages(tmp_path: Path, node: str) -> list[str]:
    tree = tmp_path / "t.yaml"
    tree.write_text(f"root: {node}\n")
    with pytest.raises(ValidationFailed) as exc:
        load_tree(tree, robot=load_robot())
    return [e.message for e in exc.value.errors]


def test_over_limit_torque_is_refused_at_the_callers_line(ctx: BuildContext) -> None:
    with pytest.raises(ValidationFailed) as exc:
        line = _next_line()
        Clamp.from_params("clamp front", ClampParams(half=Half.FRONT, torque=50), ctx)
    error = _only(exc)
    assert Path(error.location.file).resolve() == HERE
    assert (error.location.line, error.location.column) == (line, 1)
    assert error.message.startswith("clamp front: torque: 50 N*m is above the bend joints' limit")
    assert str(exc.value) == f"{error.location.file}:{line}:1: {error.message}"
    assert not Path(error.location.file).is_absolute()  # shown relative to the cwd


def test_build_checks_limits_like_yaml(ctx: BuildContext, tmp_path: Path) -> None:
    with pytest.raises(ValidationFailed) as exc:
        Clamp.build("clamp front", ctx, half="front", torque="50 N*m")
    yaml = _yaml_messages(tmp_path, "{type: clamp, half: front, torque: 50 N*m}")
    assert yaml == [_only(exc).message.replace("clamp front: ", "clamp: ", 1)]


def test_no_robot_no_limit_check() -> None:
    node = Clamp.build("clamp front", half="front", torque="50 N*m")
    assert node.params.torque == 50.0  # type: ignore[attr-defined]


def test_unit_text_is_parsed_and_params_are_si(ctx: BuildContext) -> None:
    node = Clamp.build("clamp front", ctx, half="front", torque="500 mN*m", timeout="250 ms")
    assert isinstance(node, Clamp)
    params = node.params
    assert isinstance(params, ClampParams)
    assert params.half is Half.FRONT
    assert math.isclose(params.torque, 0.5)
    assert math.isclose(params.timeout, 0.25)
    # numbers are SI, as everywhere in Python
    same = Clamp.from_params("c", {"half": "front", "torque": 0.5, "timeout": 0.25}, ctx)
    assert same.params == params  # type: ignore[attr-defined]


def test_wrong_unit_is_named(ctx: BuildContext, tmp_path: Path) -> None:
    with pytest.raises(ValidationFailed) as exc:
        line = _next_line()
        Clamp.build("clamp rear", ctx, half="rear", torque="2 deg")
    error = _only(exc)
    assert str(error) == (
        f"{error.location.file}:{line}:1: clamp rear: torque: '2 deg' is an angle,"
        " but a torque is expected (e.g. '1 N*m')"
    )
    # The file says the same, at the key (so without the key's name in front).
    yaml = _yaml_messages(tmp_path, "{type: clamp, half: rear, torque: 2 deg}")
    assert yaml == ["clamp: '2 deg' is an angle, but a torque is expected (e.g. '1 N*m')"]


def test_unknown_key_has_the_yaml_message(ctx: BuildContext, tmp_path: Path) -> None:
    with pytest.raises(ValidationFailed) as exc:
        line = _next_line()
        Clamp.build("clamp rear", ctx, half="rear", torque="0.5 N*m", torq="1 N*m")
    error = _only(exc)
    assert str(error) == f"{error.location.file}:{line}:1: clamp rear: unknown key 'torq'"
    yaml = _yaml_messages(tmp_path, "{type: clamp, half: rear, torque: 0.5 N*m, torq: 1 N*m}")
    assert yaml == ["clamp: unknown key 'torq'"]


def test_every_problem_is_reported(ctx: BuildContext) -> None:
    with pytest.raises(ValidationFailed) as exc:
        Clamp.from_params("c", {"half": "middle", "timeout": 0}, ctx)
    assert [e.message for e in exc.value.errors] == [
        "c: half: 'middle' is not one of front, rear",
        "c: missing required key 'torque'",
        "c: timeout: must be more than 0, not 0",
    ]


def test_not_params_is_refused(ctx: BuildContext) -> None:
    with pytest.raises(ValidationFailed) as exc:
        Clamp.from_params("c", [0.5], ctx)
    assert _only(exc).message == (
        "c: parameters: expected ClampParams or a mapping of its keys, got list"
    )


def test_decorator_built_with_a_child() -> None:
    clock = SimClock()
    ctx = BuildContext(clock=clock)
    step = Timeout.build(
        "limit", ctx, duration="500 ms", child=Wait.build("pause", ctx, duration="2 s")
    )
    assert isinstance(step, Timeout)
    assert step.params.duration == 0.5
    assert step.decorated.name == "pause"
    tree = py_trees.trees.BehaviourTree(step)
    tree.setup()
    tree.tick()
    assert step.status is Status.RUNNING
    clock.advance(1.0)
    tree.tick()
    assert step.status is Status.FAILURE  # the timeout, not the 2 s wait, ended it


def test_decorator_with_its_own_from_params_is_checked() -> None:
    # Retry overrides from_params; it still gets checked parameters.
    child = Scripted.build("s", statuses=["failure", "success"])
    retry = Retry.build("retry", child=child, attempts=2)
    assert isinstance(retry, Retry)
    with pytest.raises(ValidationFailed) as exc:
        line = _next_line()
        Retry.build("retry", child=child, attempts=0)
    assert str(_only(exc)).endswith(f":{line}:1: retry: attempts: must be at least 1, not 0")
    with pytest.raises(ValidationFailed, match="retry: unknown key 'times'"):
        Retry.from_params("retry", {"attempts": 2, "times": 3}, BuildContext(), child)


def test_decorator_without_child_is_refused() -> None:
    with pytest.raises(ValueError, match="decorator 'limit' needs a child"):
        Timeout.build("limit", duration="1 s")


TREE = """\
params:
  roll: {type: angle, default: 0 deg}
root: {type: rotate, name: turn, angle: $roll}
"""


def test_load_tree_from_python_locates_bad_params_at_the_caller(tmp_path: Path) -> None:
    tree = tmp_path / "t.yaml"
    tree.write_text(TREE)
    with pytest.raises(ValidationFailed) as exc:
        line = _next_line()
        load_tree(tree, params={"roll": "9 mm", "pitch": "1 deg"}, params_from_text=True)
    errors = exc.value.errors
    assert all(Path(e.location.file).resolve() == HERE for e in errors), str(exc.value)
    assert all(e.location.line == line for e in errors)
    file = errors[0].location.file
    assert str(exc.value).splitlines() == [
        f"{file}:{line}:1: parameter 'roll': '9 mm' is a length, but an angle is expected"
        " (e.g. '1 deg')",
        f"{file}:{line}:1: unknown parameter 'pitch' (parameters: roll)",
    ]
    # numbers (SI) from Python, same place
    with pytest.raises(ValidationFailed) as exc:
        line = _next_line()
        load_tree(tree, params={"roll": True})
    assert str(_only(exc)).startswith(f"{file}:{line}:1: parameter 'roll': ")


def test_load_tree_params_origin(tmp_path: Path) -> None:
    tree = tmp_path / "t.yaml"
    tree.write_text(TREE)
    with pytest.raises(ValidationFailed) as exc:
        load_tree(tree, params={"roll": "9 mm"}, params_from_text=True, params_origin="--param")
    assert str(_only(exc)).startswith("--param roll=9 mm: parameter 'roll': '9 mm' is a length")
    where = SourceLocation("mission.yaml", 7, 3)
    with pytest.raises(ValidationFailed) as exc:
        load_tree(tree, params={"roll": "9 mm"}, params_from_text=True, params_origin=where)
    assert str(_only(exc)).startswith("mission.yaml:7:3: parameter 'roll': '9 mm' is a length")


def test_commands_keep_param_locations(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    tree = tmp_path / "t.yaml"
    tree.write_text(TREE)
    assert main(["validate", "--param", "roll=9mm", str(tree)]) == 2
    assert "--param roll=9mm: parameter 'roll': '9mm' is a length" in capsys.readouterr().err


def test_a_value_the_caller_gave_is_the_callers_problem_where_the_tree_uses_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # Was "t.yaml:6:34: rotate: angle: 200.0° is beyond the rotation range ..." (and
    # "lib.yaml:3:22: ..." through a subtree): the tree's line, though the tree is
    # right and the value given is wrong.
    (tmp_path / "lib.yaml").write_text(
        "params:\n  a: {type: angle, default: 0 deg}\nroot: {type: rotate, angle: $a}\n"
    )
    tree = tmp_path / "t.yaml"
    tree.write_text(
        "params:\n  roll: {type: angle, default: 0 deg}\nroot:\n  type: sequence\n"
        "  children:\n    - {type: rotate, name: turn, angle: $roll}\n"
        "    - {type: subtree, ref: lib.yaml, params: {a: $roll}}\n"
    )
    where = SourceLocation("mission.yaml", 7, 3)
    with pytest.raises(ValidationFailed) as exc:
        load_tree(
            tree,
            robot=load_robot(),
            params={"roll": "200 deg"},
            params_from_text=True,
            params_origin=where,
        )
    messages = [str(e) for e in exc.value.errors]
    assert len(messages) == 2 and all(
        m.startswith("mission.yaml:7:3: parameter 'roll': rotate: angle: ") for m in messages
    )
    assert messages[0].endswith(f"(used at {tree}:6:34)")
    assert messages[1].endswith(f"(used at {tmp_path / 'lib.yaml'}:3:22)")
    # The tree's own values stay the tree's problems, the defaults too.
    tree.write_text("root: {type: rotate, angle: 900 deg}\n")
    with pytest.raises(ValidationFailed) as exc:
        load_tree(tree, robot=load_robot(), params_origin=where)
    assert str(_only(exc)).startswith(f"{tree}:1:22: rotate: angle: ")
    tree.write_text(TREE)
    assert main(["validate", "--param", "roll=900deg", str(tree)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("--param roll=900deg: parameter 'roll': rotate: angle: ")
    assert err.endswith(f" (used at {tree}:3:34)\n")


def test_yaml_limits_are_reported_once(tmp_path: Path) -> None:
    # The loader checks before building and from_params checks again: no change.
    messages = _yaml_messages(tmp_path, "{type: rotate, name: turn, angle: 900 deg}")
    assert len(messages) == 1 and messages[0].startswith("rotate: angle: ")
