"""Probe 18 (hostile tree files and the node catalogue): what a user saw, each pinned.

- A blackboard key that is no identifier (``key: 'a b'`` in ``set_blackboard`` or
  ``check_blackboard``, ``blackboard: 'a b'`` in a guard) was refused in pydantic's
  words, without the key or the value: *String should match pattern
  '^[A-Za-z_][A-Za-z0-9_]*$'*; an empty one *String should have at least 1 character*.
  A robot file's module named ``Bend 1`` or 50 characters long was told the same.
- A tree nested 5000 levels deep in flow style (``{type: inverter, child: {...}}``) was
  "YAML syntax error: exceeded maximum nesting depth" (libyaml's bound), though the
  syntax is fine and docs/trees.md says values nested deeper than 256 levels are refused.
- A guard with an empty list of conditions (``skip_if``/``failure_if``/``while`` with
  ``condition: []``) loaded clean and held vacuously: ``skip_if`` skipped its child
  every time (a success, the child never run), ``failure_if`` always failed, ``while``
  guarded nothing; ``eternal_guard`` with ``conditions: []`` was already refused.
- A file of two YAML documents (``---`` between two trees) was "YAML syntax error: but
  found another document": half of PyYAML's sentence, and the syntax is fine.
- A subtree named ``grip.yaml`` (or ``a#b``) loaded clean, though no ``ref`` can call it:
  ``ref: grip.yaml`` is the file of that name (the named subtree silently never used, or
  *subtree file 'grip.yaml' not found* beside a tree of that very name).
- A tab in a tree's indentation, or a value starting with ``@`` or a backquote, was
  "YAML syntax error: found character that cannot start any token", naming no character.
- ``check_blackboard`` (or a guard's ``blackboard:`` comparison) of a key declared
  ``length`` with ``value: 2 m`` and no ``unit:`` validated "ok", and every run failed at
  it: *gap=1.0 < '2 m': cannot compare float with str*.
- Sibling names ``grip`` and ``grip`` + U+200B (zero width space), or a name holding
  U+202E (shown reversed), loaded clean: two node paths that look the same everywhere
  a name is shown (the live view, ``trace show``, the diagram).
- ``type: $p`` or ``ref: $p`` was *unknown node type '$p'* / *no subtree named '$p'*,
  not saying that these keys take no parameter (docs/trees.md: never substituted).
- A ``log`` node's message wrote its escape sequences to the terminal as they were: a
  tree file could clear the screen, colour the text or go back over a line
  (``"\\e[2J"``, ``"\\r"``) in the run's output. So did a ``safe_state``'s ``reason``
  (logged by the supervisor) and a ``confirm``'s ``step`` (shown to the operator).
- A guard's comparison with a ``value`` of no allowed shape (``value: [1]``) was two
  lines, the second *condition: should be a list*, though the file wrote a comparison
  (docs/trees.md: only the shape the file used is reported on).
- A guard's ``unit: furlong`` was *dimension: unknown dimension 'furlong'*, naming a
  key the file does not have.
- ``Wait.build("w", duration="1 s", child=...)`` (a leaf given a child) built the leaf
  and dropped the child: the planner's subtree never ran, and nothing said so; a
  decorator given ``child="success"`` raised py_trees' TypeError naming no node.
"""

from __future__ import annotations

import logging
from pathlib import Path

import pytest

from pirate_bt.cli import main


def _validate(capsys: pytest.CaptureFixture[str], *paths: Path) -> list[str]:
    assert main(["validate", *map(str, paths)]) == 2
    return capsys.readouterr().err.strip().splitlines()


def test_a_key_of_the_wrong_form_is_said_in_the_file_s_words(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    tree = tmp_path / "t.yaml"
    tree.write_text(
        "blackboard: {x: {type: number, default: 1}}\n"
        "root:\n"
        "  type: sequence\n"
        "  children:\n"
        "    - {type: check_blackboard, key: 'a b', op: '<', value: 1}\n"
        "    - {type: set_blackboard, key: '', value: 1}\n"
        "    - type: skip_if\n"
        "      condition: {blackboard: 'a b', op: '<', value: 1}\n"
        "      child: success\n",
        encoding="utf-8",
    )
    lines = _validate(capsys, tree)
    assert not any("should" in line or "pattern" in line for line in lines), lines
    assert f"{tree}:5:32: check_blackboard: key: 'a b' must be an identifier" in lines[0]
    assert lines[1] == f"{tree}:6:30: set_blackboard: key: must not be empty"
    assert f"{tree}:8:19: skip_if: blackboard: 'a b' must be a blackboard key" in lines[2]


def test_a_robot_module_name_of_the_wrong_form_says_the_name(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    text = Path("hardware/pirate.yaml").read_text(encoding="utf-8")
    assert "{name: bend_1," in text
    robot = tmp_path / "r.yaml"
    robot.write_text(text.replace("{name: bend_1,", "{name: Bend 1,", 1), encoding="utf-8")
    (line,) = _validate(capsys, robot)
    assert line.endswith("name: 'Bend 1' must be lower_snake_case (the pattern [a-z][a-z0-9_]*)")
    robot.write_text(
        text.replace("{name: bend_1,", "{name: " + "b" * 50 + ",", 1), encoding="utf-8"
    )
    (line,) = _validate(capsys, robot)
    assert line.endswith("name: must be at most 40 characters long, not 50")


def test_a_tree_nested_5000_deep_in_flow_style_is_said_as_too_deep(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    depth = 5000
    tree = tmp_path / "deep.yaml"
    tree.write_text(
        "root: " + "{type: inverter, child: " * depth + "success" + "}" * depth + "\n",
        encoding="utf-8",
    )
    (line,) = _validate(capsys, tree)
    assert line.startswith(f"{tree}:1:")
    assert line.endswith(": values nested deeper than 256 levels"), line


@pytest.mark.parametrize("guard", ["skip_if", "failure_if", "while"])
def test_a_guard_with_an_empty_list_of_conditions_is_refused(
    guard: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    tree = tmp_path / "g.yaml"
    tree.write_text(
        f"root:\n  type: {guard}\n  condition: []\n  child: {{type: log, message: ran}}\n",
        encoding="utf-8",
    )
    assert _validate(capsys, tree) == [
        f"{tree}:3:3: {guard}: condition: must have at least 1 item, not 0"
    ]


def test_a_stream_of_two_documents_is_said_so_not_a_syntax_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    tree = tmp_path / "two.yaml"
    tree.write_text("root: success\n---\nroot: failure\n", encoding="utf-8")
    assert _validate(capsys, tree) == [
        f"{tree}:2:1: a second YAML document (after '---'): a file holds one"
    ]


def test_a_subtree_name_no_ref_can_name_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "grip.yaml").write_text("root: success\n", encoding="utf-8")
    tree = tmp_path / "t.yaml"
    tree.write_text(
        "root: {type: subtree, ref: grip.yaml}\n"
        "subtrees:\n"
        "  grip.yaml: {root: failure}\n"
        "  'a#b': {root: failure}\n"
        "  ok: {root: success}\n",
        encoding="utf-8",
    )
    lines = _validate(capsys, tree)
    assert [line.split(": no ref")[0] for line in lines] == [
        f"{tree}:3:3: subtree name 'grip.yaml'",
        f"{tree}:4:3: subtree name 'a#b'",
    ]


def test_a_tab_or_a_reserved_character_is_named(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    tab = tmp_path / "tab.yaml"
    tab.write_text("root:\r\n\ttype: success\r\n", encoding="utf-8")
    at = tmp_path / "at.yaml"
    at.write_text("\ufeffroot: {type: é, message: @x}\n", encoding="utf-8")
    assert _validate(capsys, tab) == [
        f"{tab}:2:1: YAML syntax error: a tab, where YAML indents with spaces"
    ]
    assert _validate(capsys, at) == [f"{at}:1:26: YAML syntax error: '@' cannot start a value"]


def test_text_compared_with_a_number_key_is_refused_at_load(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    tree = tmp_path / "cmp.yaml"
    tree.write_text(
        "blackboard:\n"
        "  gap: {type: length, default: 1 m}\n"
        "  n: {type: number, default: 1}\n"
        "  s: {type: string, default: a}\n"
        "root:\n"
        "  type: sequence\n"
        "  children:\n"
        "    - {type: check_blackboard, key: gap, op: '<', value: 2 m}\n"
        "    - type: while\n"
        "      condition: {blackboard: n, op: '<', value: '9'}\n"
        "      child: {type: check_blackboard, key: s, op: '==', value: b}\n"
        "    - {type: check_blackboard, key: gap, op: '<', value: 2 m, unit: length}\n",
        encoding="utf-8",
    )
    assert _validate(capsys, tree) == [
        f"{tree}:8:7: check_blackboard: value: '2 m' is text, but blackboard key 'gap' is"
        " declared length (text never equals a number and cannot be ordered with one);"
        " give 'unit: length' to compare a quantity",
        f"{tree}:9:7: while: value: '9' is text, but blackboard key 'n' is declared number"
        " (text never equals a number and cannot be ordered with one)",
    ]


def test_a_name_with_an_invisible_or_direction_character_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    tree = tmp_path / "n.yaml"
    tree.write_text(
        "root:\n"
        "  type: sequence\n"
        "  children:\n"
        "    - {type: success, name: grip}\n"
        '    - {type: success, name: "grip\\u200b"}\n'
        '    - {type: success, name: "\\u202egrip"}\n'
        '    - {type: success, name: "\\U0001F468\\u200d\\U0001F469"}\n',
        encoding="utf-8",
    )
    assert [line.split(" (an invisible")[0] for line in _validate(capsys, tree)] == [
        f"{tree}:5:23: name: must not contain U+200B ZERO WIDTH SPACE",
        f"{tree}:6:23: name: must not contain U+202E RIGHT-TO-LEFT OVERRIDE",
    ]


def test_a_parameter_as_a_type_or_ref_says_they_take_none(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    tree = tmp_path / "p.yaml"
    tree.write_text(
        "params: {p: {type: string, default: s}}\n"
        "root:\n"
        "  type: sequence\n"
        "  children:\n"
        "    - {type: $p}\n"
        "    - {type: subtree, ref: $p}\n"
        "subtrees: {s: {root: success}}\n",
        encoding="utf-8",
    )
    said = " (type, name and ref take no $parameter: they are written as they are)"
    assert _validate(capsys, tree) == [
        f"{tree}:5:8: unknown node type '$p'{said}",
        f"{tree}:6:23: no subtree named '$p'{said}",
    ]


def test_a_log_message_s_escape_sequences_reach_no_terminal(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    tree = tmp_path / "esc.yaml"
    tree.write_text(
        'root: {type: log, message: "hi\\e[2J\\e[31m done OK\\rnext\\n\\tline 2",'
        " level: warning}\n",
        encoding="utf-8",
    )
    with caplog.at_level(logging.WARNING, logger="pirate_bt.trees"):
        assert main(["run", "-q", str(tree)]) == 0
    (said,) = [r.getMessage() for r in caplog.records if r.name == "pirate_bt.trees"]
    assert said == "hi\\x1b[2J\\x1b[31m done OK\\rnext\n\tline 2"


def test_an_operator_step_or_a_safe_state_reason_holds_no_control_character(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    tree = tmp_path / "ops.yaml"
    tree.write_text(
        "root:\n"
        "  type: sequence\n"
        "  children:\n"
        '    - {type: safe_state, reason: "x\\e[2J"}\n'
        '    - {type: confirm, step: "go\\r", child: success}\n'
        "    - {type: safe_state, reason: fine é}\n",
        encoding="utf-8",
    )
    assert _validate(capsys, tree) == [
        f"{tree}:4:26: safe_state: reason: must not contain control characters ('\\x1b')",
        f"{tree}:5:23: confirm: step: must not contain control characters ('\\r')",
    ]


def test_a_comparison_s_bad_value_is_one_line_not_also_should_be_a_list(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    tree = tmp_path / "c.yaml"
    tree.write_text(
        "root:\n"
        "  type: while\n"
        "  condition: {state: imu.pitch, op: '<', value: [1]}\n"
        "  child: success\n",
        encoding="utf-8",
    )
    assert _validate(capsys, tree) == [
        f"{tree}:3:42: while: value: should be true or false or a whole number or a number or text"
    ]


def test_a_guard_s_unknown_unit_names_the_unit_key(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    tree = tmp_path / "u.yaml"
    tree.write_text(
        "blackboard: {gap: {type: length, default: 1 m}}\n"
        "root:\n"
        "  type: while\n"
        "  condition: {blackboard: gap, op: '<', value: 2 m, unit: furlong}\n"
        "  child: success\n",
        encoding="utf-8",
    )
    (line,) = _validate(capsys, tree)
    assert line.startswith(f"{tree}:4:3: while: unit: 'furlong' is not one of dimensionless, "), (
        line
    )
    slash = tmp_path / "slash.yaml"  # a guard's key with its leading '/' is the key
    slash.write_text(
        "blackboard: {n: {type: number, default: 1}}\n"
        "root: {type: skip_if, condition: {blackboard: /n, op: '<', value: '9'}, child: success}\n",
        encoding="utf-8",
    )
    (line,) = _validate(capsys, slash)
    assert line.startswith(f"{slash}:2:1: skip_if: value: '9' is text, but blackboard key 'n'")


def test_a_leaf_built_with_a_child_is_refused_not_run_without_it() -> None:
    from pirate_bt.behaviours.basic import Inverter, Success, Wait
    from pirate_bt.errors import ArgumentTypeError

    with pytest.raises(ArgumentTypeError, match=r"^Wait\(w\): child: a leaf takes no child"):
        Wait.build("w", duration="1 s", child=Success.build("s"))
    with pytest.raises(ArgumentTypeError, match=r"^Inverter\(i\): child: give a py_trees"):
        Inverter.build("i", child="success")
    assert Inverter.build("i", child=Success.build("s")).children[0].name == "s"


def test_a_file_name_with_an_escape_sequence_is_shown_escaped_in_its_location(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # a path holding ESC [2J (clear the screen) or a line break reached the terminal as
    # written in every file:line:column
    from pirate_bt.cli import main

    bad = tmp_path / "a\x1b[2Jb\nc.yaml"
    bad.write_text("x: [\n")
    assert main(["validate", str(bad)]) == 2
    err = capsys.readouterr().err
    assert "\x1b" not in err and "a\\x1b[2Jb\\nc.yaml:1:5: " in err, err
