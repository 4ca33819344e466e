"""Probe 8 (hostile trees): tree parameters of type ``number`` and ``integer``.

A ``number`` parameter took NaN and the infinities (``--param x=nan``, ``default:
.nan`` in a file, ``<input_port type="number" default="nan">`` in XML), which a
quantity refuses: ``check_blackboard`` with ``op: '!='`` and a NaN value then
always succeeded. Text also took what Python's ``int`` and ``float`` take beyond the
ASCII digits the docs promise (``1_000``, ``٣``), and a value thousands of characters
long was repeated whole in the message.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from pirate_bt.cli import main
from pirate_bt.errors import ValidationFailed
from pirate_bt.treefile import load_tree

TREE = """\
params:
  x: {type: number, default: 1}
  n: {type: integer, default: 1}
blackboard:
  v: {type: number, default: 0}
root:
  type: sequence
  children:
    - {type: set_blackboard, key: v, value: $x}
    - {type: retry, attempts: $n, child: success}
    - {type: check_blackboard, key: v, op: '!=', value: $x}
"""


@pytest.fixture
def tree(tmp_path: Path) -> Path:
    path = tmp_path / "tree.yaml"
    path.write_text(TREE, encoding="utf-8")
    return path


@pytest.mark.parametrize(
    "given",
    ["x=nan", "x=inf", "x=-Infinity", "x=1e999", "x=1_0", "x=\u0661", "n=1_000", "n=\u0663"],
)
def test_command_line_numbers_are_finite_ascii(
    tree: Path, given: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["run", str(tree), "--quiet", "--param", given]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert err.startswith(f"pirate-bt: --param {given}: parameter ")
    assert repr(given.partition("=")[2]) in err


@pytest.mark.parametrize("given", [" 2.5 ", ".5", "5.", "-1e-3", "+3"])
def test_ordinary_numbers_still_read(tree: Path, given: str) -> None:
    loaded = load_tree(tree, params={"x": given}, params_from_text=True)
    assert loaded.params["x"] == float(given)


@pytest.mark.parametrize("value", [math.nan, math.inf, -math.inf, 10**400])
def test_python_numbers_are_finite(tree: Path, value: float) -> None:
    with pytest.raises(ValidationFailed, match="expected a finite number"):
        load_tree(tree, params={"x": value})


@pytest.mark.parametrize("key", ["default", "example"])
@pytest.mark.parametrize("value", [".nan", ".inf", "-.inf"])
def test_a_declared_non_finite_number_is_refused_where_written(
    tmp_path: Path, key: str, value: str
) -> None:
    path = tmp_path / "tree.yaml"
    path.write_text(f"params:\n  x: {{type: number, {key}: {value}}}\nroot: success\n")
    with pytest.raises(ValidationFailed) as caught:
        load_tree(path, use_examples=True)
    (error,) = caught.value.errors
    assert str(error).startswith(f"{path}:2:")
    assert f"{key}: expected a finite number" in str(error)


def test_a_nan_port_default_in_xml_is_refused_at_its_port(tmp_path: Path) -> None:
    from pirate_bt.interop import load_xml_tree

    path = tmp_path / "tree.xml"
    path.write_text(
        '<root BTCPP_format="4" main_tree_to_execute="main">\n'
        '  <BehaviorTree ID="main"><AlwaysSuccess /></BehaviorTree>\n'
        "  <TreeNodesModel>\n"
        '    <SubTree ID="main">\n'
        '      <input_port name="x" type="number" default="nan" />\n'
        "    </SubTree>\n"
        "  </TreeNodesModel>\n"
        "</root>\n",
        encoding="utf-8",
    )
    with pytest.raises(ValidationFailed) as caught:
        load_xml_tree(path)
    (error,) = caught.value.errors
    assert str(error).startswith(f"{path}:5:")
    assert "expected a finite number" in str(error)


def test_long_values_and_names_are_cut_short(
    tree: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    for given in (f"n={'1' * 5000}", f"{'z' * 5000}=1"):
        assert main(["validate", "--param", given, str(tree)]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1
        assert len(err) < 300, err[:300]


def test_a_non_finite_blackboard_default_is_refused_where_written(tmp_path: Path) -> None:
    path = tmp_path / "tree.yaml"
    path.write_text(
        "blackboard:\n  x: {type: number, default: .nan}\n  y: {default: [1, -.inf]}\n"
        "root: success\n",
        encoding="utf-8",
    )
    with pytest.raises(ValidationFailed) as caught:
        load_tree(path)
    assert [str(e) for e in caught.value.errors] == [
        f"{path}:2:21: a number in the default must be finite, not nan",
        f"{path}:3:7: a number in the default must be finite, not -inf",
    ]
    with pytest.raises(ValidationFailed, match="must be finite"):
        load_tree({"blackboard": {"x": {"default": math.nan}}, "root": "success"})


@pytest.mark.parametrize(
    ("text", "place", "message"),
    [
        # roll: {type: angle, default: 90} was 90 rad (5157 degrees), silently
        (
            "params:\n  roll: {type: angle, default: 90}\nroot: success\n",
            "2:23",
            "default: 90 needs a unit: write it as e.g. '90 rad' or '5157 deg'",
        ),
        (
            "params:\n  d: {type: duration, example: 5}\nroot: success\n",
            "2:23",
            "example: 5 needs a unit: write it as e.g. '5 s'",
        ),
        (
            "root: {type: subtree, ref: s, params: {d: 5}}\n"
            "subtrees:\n  s:\n    params: {d: duration}\n    root: {type: wait, duration: $d}\n",
            "1:40",
            "parameter 'd': 5 needs a unit: write it as e.g. '5 s'",
        ),
    ],
)
def test_a_quantity_written_in_a_file_needs_its_unit(
    tmp_path: Path, text: str, place: str, message: str
) -> None:
    path = tmp_path / "tree.yaml"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(ValidationFailed) as caught:
        load_tree(path, use_examples=True)
    assert [str(e) for e in caught.value.errors] == [f"{path}:{place}: {message}"]


def test_numbers_are_si_in_python_and_zero_needs_no_unit(tmp_path: Path) -> None:
    mapping = {
        "params": {"d": {"type": "duration", "default": 5}},
        "root": {"type": "subtree", "ref": "s", "params": {"d": 2}},
        "subtrees": {
            "s": {"params": {"d": "duration"}, "root": {"type": "wait", "duration": "$d"}}
        },
    }
    assert load_tree(mapping).params == {"d": "5.0 s"}
    path = tmp_path / "tree.yaml"
    path.write_text("params:\n  roll: {type: angle, default: 0}\nroot: success\n")
    assert load_tree(path).params == {"roll": "0.0 rad"}
    assert load_tree(path, params={"roll": 1.5}).params == {"roll": "1.5 rad"}


def test_a_quantity_key_s_default_is_si(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # 'dist: {type: length, default: 1 m}' put the text '1 m' on the blackboard, so a
    # check_blackboard with unit: length compared '1 m' < 2.0 and failed ("dist='1 m' <
    # 2.0: False"); a bare number was SI and worked.
    tree = tmp_path / "tree.yaml"
    tree.write_text(
        "blackboard:\n  dist: {type: length, default: 1 m}\n  t: {type: duration, default: 2}\n"
        "root:\n  type: sequence\n  children:\n"
        "    - {type: check_blackboard, key: dist, op: '<', value: 2 m, unit: length}\n"
        "    - {type: check_blackboard, key: t, op: '==', value: 2 s, unit: time}\n",
        encoding="utf-8",
    )
    assert main(["run", str(tree), "--quiet"]) == 0, capsys.readouterr().err
    assert load_tree(tree).blackboard_defaults() == {"dist": 1.0, "t": 2.0}
    # and it goes to BT.CPP's XML and back as SI
    xml = tmp_path / "tree.xml"
    back = tmp_path / "back.yaml"
    assert main(["export", "btcpp", str(tree), "-o", str(xml)]) == 0
    assert main(["import", "btcpp", str(xml), "-o", str(back)]) == 0
    assert load_tree(back).blackboard_defaults() == {"dist": 1.0, "t": 2.0}
    tree.write_text("blackboard:\n  dist: {type: length, default: 1 s}\nroot: success\n")
    with pytest.raises(ValidationFailed) as caught:
        load_tree(tree)
    assert [str(e) for e in caught.value.errors] == [
        f"{tree}:2:24: default: '1 s' is a time, but a length is expected (e.g. '1 m')"
    ]
