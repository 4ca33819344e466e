"""YAML trees: same statuses as hand-built trees, parameters, subtrees, blackboard, checks."""

from __future__ import annotations

from pathlib import Path

import py_trees
import pytest
from py_trees.common import Status

from pirate_bt.behaviours.base import BuildContext
from pirate_bt.behaviours.basic import (
    Inverter,
    Repeat,
    RepeatParams,
    Retry,
    RetryParams,
    Scripted,
    ScriptedParams,
    Wait,
    WaitParams,
)
from pirate_bt.clock import SimClock
from pirate_bt.errors import ValidationFailed
from pirate_bt.resources import data_dir
from pirate_bt.robot import load_robot
from pirate_bt.treefile import load_tree, tree_schema

DATA = Path(__file__).parent / "data" / "trees"


@pytest.fixture(autouse=True)
def _clean_blackboard() -> None:
    py_trees.blackboard.Blackboard.clear()


def _scripted(name: str, statuses: list[str], then: str = "hold") -> Scripted:
    params = ScriptedParams.model_validate({"statuses": statuses, "then": then})
    return Scripted(name, params, BuildContext())


def _by_hand() -> py_trees.behaviour.Behaviour:
    ctx = BuildContext()
    steps = py_trees.composites.Sequence(
        "steps",
        True,
        [
            _scripted("a", ["running", "success", "success", "failure", "success"]),
            Inverter.from_params(
                "not b", None, ctx, _scripted("b", ["failure", "running", "success", "failure"])
            ),
            Retry.from_params(
                "retry c",
                RetryParams(attempts=2),
                ctx,
                _scripted("c", ["failure", "running", "success", "failure", "failure"]),
            ),
        ],
    )
    both = py_trees.composites.Parallel(
        "both",
        py_trees.common.ParallelPolicy.SuccessOnOne(),
        [
            _scripted("d", ["running", "failure", "success"]),
            Repeat.from_params(
                "twice e",
                RepeatParams(times=2),
                ctx,
                _scripted("e", ["success", "running"], "cycle"),
            ),
        ],
    )
    fallback = _scripted("fallback", ["failure", "success"], "cycle")
    return py_trees.composites.Selector("top", False, [steps, both, fallback])


def _statuses(root: py_trees.behaviour.Behaviour, ticks: int) -> list[list[tuple[str, str]]]:
    tree = py_trees.trees.BehaviourTree(root)
    out = []
    for _ in range(ticks):
        tree.tick()
        out.append([(n.name, n.status.value) for n in root.iterate()])
    return out


def test_yaml_and_hand_built_trees_tick_identically() -> None:
    loaded = load_tree(DATA / "equivalence.yaml")
    from_yaml = _statuses(loaded.root, 30)
    by_hand = _statuses(_by_hand(), 30)
    assert from_yaml == by_hand
    assert {s for tick in from_yaml for _, s in tick} >= {"SUCCESS", "FAILURE", "RUNNING"}


def test_a_dict_gives_the_same_tree_as_the_file() -> None:
    from pirate_bt.yamlfile import load_yaml

    data = load_yaml(DATA / "equivalence.yaml").data
    assert _statuses(load_tree(data).root, 20) == _statuses(
        load_tree(DATA / "equivalence.yaml").root, 20
    )


def test_shipped_example_trees_validate_and_succeed() -> None:
    from pirate_bt.runner import Runner

    robot = load_robot()
    examples = sorted((data_dir("trees") / "examples").glob("*.yaml"))
    assert len(examples) >= 2
    for path in examples:
        clock = SimClock()
        tree = load_tree(path, robot=robot, clock=clock)
        assert not tree.warnings
        result = Runner(tree, clock=clock, period_s=0.05, max_time_s=60).run()
        assert result.succeeded, (path, result.message)


def test_parameters_are_typed_substituted_and_overridable() -> None:
    tree = {
        "params": {"pause": {"type": "duration", "default": "2 s"}},
        "root": {"type": "wait", "duration": "$pause"},
    }
    assert load_tree(tree).root.duration_s == pytest.approx(2.0)  # type: ignore[attr-defined]
    given = load_tree(tree, params={"pause": "250 ms"}, params_from_text=True)
    assert given.root.duration_s == pytest.approx(0.25)  # type: ignore[attr-defined]
    si = load_tree(tree, params={"pause": 0.5})
    assert si.root.duration_s == 0.5  # type: ignore[attr-defined]
    with pytest.raises(ValidationFailed, match=r"needs a unit|is a length"):
        load_tree(tree, params={"pause": "3 mm"}, params_from_text=True)
    with pytest.raises(ValidationFailed, match="unknown parameter 'paws'"):
        load_tree(tree, params={"paws": "1 s"}, params_from_text=True)


def test_literal_dollar_and_no_expressions() -> None:
    tree = {"root": {"type": "log", "message": "$$HOME"}}
    assert load_tree(tree).root.message == "$HOME"  # type: ignore[attr-defined]
    with pytest.raises(ValidationFailed, match="write \\$name"):
        load_tree({"root": {"type": "log", "message": "$(rm -rf /)"}})


def test_a_parameter_default_unescapes_dollars_as_a_node_value_does() -> None:
    # the default "$$fromdefault" ran as "$$fromdefault", while "value: $$direct" gave "$direct"
    tree = {
        "params": {"g": {"type": "string", "default": "$$fromdefault"}},
        "root": {"type": "log", "message": "$g"},
    }
    assert load_tree(tree).root.message == "$fromdefault"  # type: ignore[attr-defined]
    assert load_tree(tree).params == {"g": "$fromdefault"}
    example = {"params": {"g": {"type": "string", "example": "$$x"}}, "root": tree["root"]}
    assert load_tree(example, use_examples=True).root.message == "$x"  # type: ignore[attr-defined]
    # a caller's value is not a tree file: taken as it is, from the command line or Python
    cli = load_tree(tree, params={"g": "$$cli"}, params_from_text=True)
    assert cli.root.message == "$$cli"  # type: ignore[attr-defined]
    assert load_tree(tree, params={"g": "$py"}).root.message == "$py"  # type: ignore[attr-defined]
    # "$x" in a default names no parameter (it did mean the literal "$x")
    single = {"params": {"g": {"type": "string", "default": "$x"}}, "root": tree["root"]}
    with pytest.raises(ValidationFailed, match=r"default: '\$x': .*write \$\$x for the literal"):
        load_tree(single)


def test_unnamed_siblings_get_distinct_names() -> None:
    root = load_tree({"root": {"type": "sequence", "children": ["success", "success"]}}).root
    assert [c.name for c in root.children] == ["success", "success 2"]


def test_children_that_can_never_run_are_warned_about() -> None:
    tree = load_tree(
        {
            "root": {
                "type": "selector",
                "children": [
                    {"type": "sequence", "children": ["failure", "success"]},
                    "success",
                    {"type": "wait", "duration": 1.0},
                ],
            }
        }
    )
    messages = [w.message for w in tree.warnings]
    assert any("'success' can never run: 'failure'" in m for m in messages)
    assert any("'wait' can never run: 'success' before it in selector" in m for m in messages)


def test_blackboard_defaults_and_checks() -> None:
    clock = SimClock()
    tree = load_tree(
        {
            "blackboard": {"flag": {"default": 3}},
            "root": {"type": "check_blackboard", "key": "flag", "op": ">=", "value": 2},
        },
        clock=clock,
    )
    tree.write_blackboard_defaults()
    bt = tree.behaviour_tree()
    bt.tick()
    assert bt.root.status == Status.SUCCESS


def test_quantities_on_the_blackboard_are_si() -> None:
    tree = load_tree(
        {
            "blackboard": {"roll": {"type": "angle"}},
            "root": {
                "type": "sequence",
                "children": [
                    {"type": "set_blackboard", "key": "roll", "value": "90 deg", "unit": "angle"},
                    {
                        "type": "check_blackboard",
                        "key": "roll",
                        "op": ">",
                        "value": "1.5 rad",
                        "unit": "angle",
                    },
                ],
            },
        }
    )
    bt = tree.behaviour_tree()
    bt.tick()
    assert bt.root.status == Status.SUCCESS


def test_timeout_and_wait_read_the_injected_clock() -> None:
    clock = SimClock()
    tree = load_tree(
        {"root": {"type": "timeout", "duration": 1.0, "child": {"type": "wait", "duration": 5.0}}},
        clock=clock,
    )
    bt = tree.behaviour_tree()
    bt.tick()
    assert bt.root.status == Status.RUNNING
    clock.advance(0.99)
    bt.tick()
    assert bt.root.status == Status.RUNNING
    clock.advance(0.02)
    bt.tick()
    assert bt.root.status == Status.FAILURE
    assert bt.root.children[0].status == Status.INVALID


def test_nodes_can_be_built_in_code_without_a_robot() -> None:
    clock = SimClock()
    wait = Wait.from_params("pause", WaitParams(duration=0.1), BuildContext(clock=clock))
    bt = py_trees.trees.BehaviourTree(wait)
    bt.setup()
    bt.tick()
    clock.advance(0.1)
    bt.tick()
    assert wait.status == Status.SUCCESS


def test_schema_lists_every_node_type_and_accepts_parameters() -> None:
    schema = tree_schema()
    titles = {v.get("title") for v in schema["$defs"]["node"]["anyOf"]}
    assert {"sequence", "selector", "parallel", "subtree", "eternal_guard", "wait"} <= titles
    wait = next(v for v in schema["$defs"]["node"]["anyOf"] if v.get("title") == "wait")
    assert wait["required"] == ["type", "duration"]
    assert wait["additionalProperties"] is False


def test_a_value_given_at_a_subtree_call_is_reported_at_the_call(tmp_path: Path) -> None:
    # It was reported only inside the subtree, where the value is used, not written.
    (tmp_path / "hold.yaml").write_text(
        "name: hold\nparams:\n  torque: {type: torque, default: 0.5 N*m, description: t}\n"
        "root: {type: clamp, name: clamp rear, half: rear, torque: $torque}\n",
        encoding="utf-8",
    )
    main = tmp_path / "main.yaml"
    main.write_text(
        "name: main\nroot:\n  type: sequence\n  name: main\n  children:\n"
        "    - {type: subtree, name: hold, ref: hold.yaml, params: {torque: 50 N*m}}\n"
        "    - {type: subtree, name: pass, ref: main2.yaml, params: {torque: 40 N*m}}\n",
        encoding="utf-8",
    )
    (tmp_path / "main2.yaml").write_text(  # passes its caller's value on: reported there
        "name: pass\nparams:\n  torque: {type: torque, default: 0.5 N*m, description: t}\n"
        "root: {type: subtree, name: hold, ref: hold.yaml, params: {torque: $torque}}\n",
        encoding="utf-8",
    )
    with pytest.raises(ValidationFailed) as raised:
        load_tree(main, robot=load_robot())
    texts = [str(e) for e in raised.value.errors]
    assert texts == [
        f"{main}:6:60: parameter 'torque': clamp: torque: 50 N*m is above the bend joints'"
        f" limit 0.8 N*m (used at {tmp_path / 'hold.yaml'}:4:51)",
        f"{main}:7:61: parameter 'torque': clamp: torque: 40 N*m is above the bend joints'"
        f" limit 0.8 N*m (used at {tmp_path / 'hold.yaml'}:4:51)",
    ]
