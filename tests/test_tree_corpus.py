"""Malformed trees: each gives one located error and exit code 2 through the CLI."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
from pydantic import Field

from pirate_bt.behaviours.base import Leaf, NodeParams
from pirate_bt.cli import main
from pirate_bt.robot.description import RobotDescription
from pirate_bt.treefile import default_registry
from pirate_bt.units import Angle


class BendParams(NodeParams):
    module: str = Field(description="bend module")
    angle: Angle = Field(description="joint angle")


class FakeBend(Leaf):
    """A stand-in for the bend primitive: only its limit check matters here."""

    Params = BendParams
    needs_robot = True

    @classmethod
    def check_limits(cls, params: Any, robot: RobotDescription) -> list[str]:
        try:
            limit = robot.joint_motor(params.module).limits.angle
        except KeyError:
            return [f"module: no bend module {params.module!r}"]
        if limit is not None and not limit.min <= params.angle <= limit.max:
            return [
                f"angle: {params.angle:.3f} rad is outside {limit.min:.3f}..{limit.max:.3f} rad"
            ]
        return []


@pytest.fixture(autouse=True)
def _fake_bend() -> None:
    default_registry().register("test_bend", FakeBend, replace=True)


OK_ROOT = "root: success\n"

# name -> (files, expected "line:column", expected message fragment); "tree.yaml" is validated.
CASES: dict[str, tuple[dict[str, str], str, str]] = {
    "syntax": ({"tree.yaml": "root: {type: success\n"}, "1:21", "YAML syntax error"),
    "tab indent": ({"tree.yaml": "root:\n\t- success\n"}, "2:1", "YAML syntax error"),
    "empty file": ({"tree.yaml": "\n"}, "1:1", "empty"),
    "not a mapping": ({"tree.yaml": "- root\n"}, "1:1", "a tree file is a mapping"),
    "duplicate key": ({"tree.yaml": "root: success\nroot: failure\n"}, "2:1", "duplicate key"),
    "unknown top key": ({"tree.yaml": "root: success\nroots: 1\n"}, "2:1", "unknown key 'roots'"),
    "missing root": ({"tree.yaml": "name: x\n"}, "1:1", "missing required key 'root'"),
    "unknown node": (
        {"tree.yaml": "root: {type: wiat, duration: 1 s}\n"},
        "1:8",
        "did you mean 'wait'",
    ),
    "unknown bare node": ({"tree.yaml": "root: sucess\n"}, "1:1", "did you mean 'success'"),
    "node without type": ({"tree.yaml": "root: {name: x}\n"}, "1:1", "node without 'type'"),
    "node is a list": ({"tree.yaml": "root: [success]\n"}, "1:1", "a node is a mapping"),
    "missing parameter": (
        {"tree.yaml": "root: {type: wait}\n"},
        "1:1",
        "missing required key 'duration'",
    ),
    "unknown parameter": (
        {"tree.yaml": "root: {type: wait, duration: 1 s, durration: 2 s}\n"},
        "1:35",
        "unknown key 'durration'",
    ),
    "ill-typed parameter": (
        {"tree.yaml": "root:\n  type: retry\n  attempts: many\n  child: success\n"},
        "3:3",
        "attempts",
    ),
    "bare number": ({"tree.yaml": "root: {type: wait, duration: 2}\n"}, "1:20", "needs a unit"),
    "unknown unit": (
        {"tree.yaml": "root: {type: wait, duration: 2 fortnights}\n"},
        "1:20",
        "unknown unit",
    ),
    "wrong dimension": (
        {"tree.yaml": "root: {type: wait, duration: 2 mm}\n"},
        "1:20",
        "is a length",
    ),
    "negative duration": (
        {"tree.yaml": "root: {type: wait, duration: -1 s}\n"},
        "1:20",
        "duration: must be at least 0 s, not -1 s",
    ),
    "out of limit": (
        {"tree.yaml": "root:\n  type: test_bend\n  module: bend_1\n  angle: 200 deg\n"},
        "4:3",
        "outside",
    ),
    "no such module": (
        {"tree.yaml": "root:\n  type: test_bend\n  module: bend_9\n  angle: 10 deg\n"},
        "3:3",
        "no bend module",
    ),
    "decorator without child": (
        {"tree.yaml": "root: {type: inverter}\n"},
        "1:1",
        "needs a 'child'",
    ),
    "leaf with child": (
        {"tree.yaml": "root: {type: success, child: failure}\n"},
        "1:23",
        "takes no child",
    ),
    "empty children": (
        {"tree.yaml": "root: {type: sequence, children: []}\n"},
        "1:24",
        "list of children",
    ),
    "bad memory": (
        {"tree.yaml": "root: {type: selector, memory: maybe, children: [success]}\n"},
        "1:24",
        "memory",
    ),
    "bad policy": (
        {"tree.yaml": "root: {type: parallel, policy: most, children: [success]}\n"},
        "1:24",
        "policy",
    ),
    "duplicate sibling names": (
        {
            "tree.yaml": "root:\n  type: sequence\n  children:\n    - {type: success, name: a}\n"
            "    - {type: failure, name: a}\n"
        },
        "5:7",
        "duplicate node name 'a'",
    ),
    "unknown subtree": (
        {"tree.yaml": "root: {type: subtree, ref: clmap}\nsubtrees:\n  clamp: {root: success}\n"},
        "1:23",
        "did you mean 'clamp'",
    ),
    "missing file": (
        {"tree.yaml": "root: {type: subtree, ref: other.yaml}\n"},
        "1:23",
        "not found",
    ),
    "error in included file": (
        {
            "tree.yaml": "root: {type: subtree, ref: other.yaml}\n",
            "other.yaml": "root: {type: nope}\n",
        },
        "other.yaml:1:8",
        "unknown node type 'nope'",
    ),
    "recursive include (same file)": (
        {
            "tree.yaml": "root: {type: subtree, ref: a}\nsubtrees:\n  a:\n"
            "    root: {type: subtree, ref: a}\n"
        },
        "4:27",
        "recursive subtree",
    ),
    "recursive include (two files)": (
        {
            "tree.yaml": "root: {type: subtree, ref: b.yaml}\n",
            "b.yaml": "root: {type: subtree, ref: tree.yaml}\n",
        },
        "b.yaml:1:23",
        "recursive subtree",
    ),
    "unknown $param": (
        {"tree.yaml": "root: {type: wait, duration: $pause}\n"},
        "1:20",
        "unknown parameter $pause",
    ),
    "bad param default": (
        {
            "tree.yaml": "params:\n  pause: {type: duration, default: 3 kg}\n"
            "root: {type: wait, duration: $pause}\n"
        },
        "2:27",
        "default",
    ),
    "bad param type": (
        {"tree.yaml": "params:\n  pause: {type: time}\nroot: success\n"},
        "2:11",
        "type",
    ),
    "subtree param missing": (
        {
            "tree.yaml": "root: {type: subtree, ref: w}\nsubtrees:\n  w:\n"
            "    params: {d: duration}\n"
            "    root: {type: wait, duration: $d}\n"
        },
        "1:1",
        "parameter 'd' has no default",
    ),
    "subtree param wrong unit": (
        {
            "tree.yaml": "root: {type: subtree, ref: w, params: {d: 3 m}}\nsubtrees:\n  w:\n"
            "    params: {d: duration}\n    root: {type: wait, duration: $d}\n"
        },
        "1:40",
        "parameter 'd'",
    ),
    "read never written": (
        {
            "tree.yaml": "blackboard:\n  flag: {type: boolean}\n"
            "root: {type: check_blackboard, key: flag, value: true}\n"
        },
        "3:1",
        "read but never written",
    ),
    "undeclared blackboard key": (
        {"tree.yaml": "root: {type: set_blackboard, key: flag, value: true}\n"},
        "1:1",
        "written but not declared",
    ),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_malformed_tree_is_located_and_exits_2(
    case: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    files, where, fragment = CASES[case]
    for name, text in files.items():
        (tmp_path / name).write_text(text, encoding="utf-8")
    tree = tmp_path / "tree.yaml"
    code = main(["validate", "--kind", "tree", str(tree)])
    err = capsys.readouterr().err
    assert code == 2, err
    file = where.split(":")[0] if where.count(":") == 2 else "tree.yaml"
    line_col = ":".join(where.split(":")[-2:])
    expected = f"{tmp_path / file}:{line_col}: "
    assert any(line.startswith(expected) and fragment in line for line in err.splitlines()), err


def test_corpus_is_large_enough() -> None:
    assert len(CASES) >= 25


def test_run_refuses_a_malformed_tree_with_exit_2(tmp_path: Path) -> None:
    tree = tmp_path / "tree.yaml"
    tree.write_text("root: {type: wait, duration: 2}\n", encoding="utf-8")
    assert main(["run", str(tree)]) == 2
    assert main(["run", str(tmp_path / "missing.yaml")]) == 2
    good = tmp_path / "good.yaml"
    good.write_text("params: {d: duration}\nroot: {type: wait, duration: $d}\n", encoding="utf-8")
    assert main(["run", str(good), "--param", "d=2kg"]) == 2
    assert main(["run", str(good), "--param", "d"]) == 2
    assert main(["run", str(good), "--param", "d=1 s", "--max-time", "soon"]) == 2
