"""Probe 19 (hostile tree files and the node catalogue): what a user saw, each pinned.

- A guard's comparison that could never mean anything loaded clean: ``{state: mode, op:
  '<', value: autonomous}`` and ``half.front < clamped`` compared the words' spelling,
  ``{state: link.healthy, value: maybe}`` never held (and ``value: 1`` held as true),
  and ``{state: imu.pitch, value: true}`` held when the pitch was exactly 1 rad (a
  boolean is the number 1); ``check_blackboard`` already refused a boolean with a unit.
- Sibling names ``grip`` and ``grip `` (a trailing space), `` grip`` or ``grip`` + U+00A0
  (a no-break space) loaded as two siblings that look the same wherever a name is shown,
  and a name holding U+2028 (``"a\\Lb"`` in double quotes) broke the node's path over
  two lines in the log and ``trace show``.
- ``<<: [*slow, *fast]`` took ``fast``'s ``duration`` (PyYAML 6.0.4 keeps the first of
  two merged keys only when their texts are one Python object: a one-letter key, not
  ``duration``), where YAML's merge and every editor take the first mapping's; and
  ``<<: [*fast, {duration: 3 deg}]`` was refused with *'3 deg' is an angle* placed at
  ``fast``'s ``duration: 1 s``.
- A subtree call whose ``ref`` is no name (``ref: [a.yaml]``, ``ref: ''``, ``ref: 5``)
  was told *subtree needs a 'ref'*, beside the ``ref`` it has.
- ``check_blackboard`` (or a guard's ``blackboard:`` comparison) of a key declared
  ``string`` with ``value: 5``, or of one declared ``boolean`` with ``value: 1`` or
  ``'yes'``, validated "ok" and compared a number with text (never equal) or took 1 for
  true; probe 18 refused only text compared with a key declared a number. And
  ``set_blackboard`` wrote ``'yes'`` to a key declared ``boolean`` and the text
  ``'2 m'`` (no ``unit:``) to one declared ``length``: every later comparison failed.
- A blackboard key declared ``boolean`` with ``default: maybe`` (or ``integer`` with
  ``1.5``, ``string`` with ``5``, ``number`` with ``1 m``, ``integer`` with ``$p``: a
  default takes no parameter) validated "ok" and wrote that value before the first tick.
- A pipe network or a robot description given as a tree (``pirate-bt run
  hardware/pirate.yaml``, a ``ref:`` to the wrong file) was a line for each of its
  top-level keys (*unknown key 'schema_version'*, *missing required key 'root'*, ...),
  where a tree given as a robot or a network is one line saying what it looks like.
- ``{type: drive, until: blocked, distance: 1 m}`` loaded clean and the distance was
  ignored: the drive went on to its ``max_distance`` (3 m); ``distance_key`` with
  another ``until`` was read (and could fail the drive) and ignored all the same.
- An ``eternal_guard`` whose conditions held a drive of 0.2 m (or a wait, or a sequence
  holding one) loaded clean, and on the simulator the robot drove 2.1 m in 30 s: the
  guard re-checks its conditions every tick, so each time the drive was done the next
  tick started it again, its child interrupted each time.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.cli import main


def _validate(capsys: pytest.CaptureFixture[str], *paths: Path) -> list[str]:
    assert main(["validate", *map(str, paths)]) == 2
    return capsys.readouterr().err.strip().splitlines()


def test_a_guard_comparison_that_cannot_mean_anything_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    tree = tmp_path / "t.yaml"
    tree.write_text(
        "blackboard:\n"
        "  gap: {type: length, default: 1 m}\n"
        "root:\n"
        "  type: sequence\n"
        "  children:\n"
        "    - type: skip_if\n"
        "      condition: {state: mode, op: '<', value: autonomous}\n"
        "      child: success\n"
        "    - type: skip_if\n"
        "      condition: {state: half.front, op: '>=', value: clamped}\n"
        "      child: success\n"
        "    - type: while\n"
        "      condition: {state: link.healthy, value: maybe}\n"
        "      child: success\n"
        "    - type: while\n"
        "      condition: {state: link.healthy, value: 1}\n"
        "      child: success\n"
        "    - type: failure_if\n"
        "      condition: {state: link.healthy, op: '>', value: false}\n"
        "      child: success\n"
        "    - type: failure_if\n"
        "      condition: {state: imu.pitch, value: true}\n"
        "      child: success\n"
        "    - type: failure_if\n"
        "      condition: [{blackboard: gap, unit: length, op: '<', value: false}]\n"
        "      child: success\n"
        "    - type: failure_if\n"  # what may be said stays allowed
        "      condition:\n"
        "        - {state: link.healthy, op: '!=', value: true}\n"
        "        - {state: mode, op: '!=', value: manual}\n"
        "        - {state: half.rear, value: clamped}\n"
        "        - {state: imu.pitch, op: '<', value: 10 deg}\n"
        "      child: success\n"
    )
    t = tree
    assert _validate(capsys, tree) == [
        f"{t}:7:7: skip_if: op: '<' orders numbers; mode is compared with == or !=",
        f"{t}:10:7: skip_if: op: '>=' orders numbers; half.front is compared with == or !=",
        f"{t}:13:7: while: value: link.healthy is true or false, not 'maybe'",
        f"{t}:16:7: while: value: link.healthy is true or false, not 1",
        f"{t}:19:7: failure_if: op: '>' orders numbers; link.healthy is compared with == or !=",
        f"{t}:22:7: failure_if: value: true is a boolean, but a quantity (angle) is compared:"
        " write it with its unit",
        f"{t}:25:19: failure_if: value: false is a boolean, but a quantity (length) is"
        " compared: write it with its unit",
    ]


def test_a_name_with_an_edge_space_or_an_odd_space_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    tree = tmp_path / "t.yaml"
    tree.write_text(
        'name: "patrol "\n'
        "root:\n"
        "  type: sequence\n"
        "  children:\n"
        "    - {type: success, name: grip}\n"
        '    - {type: success, name: "grip "}\n'
        '    - {type: success, name: " grip"}\n'
        '    - {type: success, name: "grip\\_x"}\n'
        '    - {type: success, name: "a\\Lb"}\n'
        '    - {type: success, name: "clamp front"}\n'
    )
    t = tree
    edge = "name: must not begin or end with a space (two names would look alike)"
    odd = "(a space other than ' ', or a line break: two names would look alike)"
    assert _validate(capsys, tree) == [
        f"{t}:1:1: {edge}",
        f"{t}:6:23: {edge}",
        f"{t}:7:23: {edge}",
        f"{t}:8:23: name: must not contain U+00A0 NO-BREAK SPACE {odd}",
        f"{t}:9:23: name: must not contain U+2028 LINE SEPARATOR {odd}",
    ]


def test_a_merge_of_two_anchors_takes_the_first_s_value_as_yaml_does(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from pirate_bt.treefile import load_tree

    tree = tmp_path / "t.yaml"
    tree.write_text(
        "root:\n"
        "  type: sequence\n"
        "  children:\n"
        "    - &slow {type: wait, name: slow, duration: 2 s}\n"
        "    - &fast {type: wait, name: fast, duration: 1 s}\n"
        "    - <<: [*slow, *fast]\n"
        "      name: merged\n"
        "    - <<: [*fast, {duration: 3 deg}]\n"
        "      name: first\n"
        "    - <<: [*slow, *fast]\n"
        "      name: own\n"
        "      duration: 4 s\n"
    )
    loaded = load_tree(tree)
    waits = {child.name: child.params.duration for child in loaded.root.children}
    assert waits == {"slow": 2.0, "fast": 1.0, "merged": 2.0, "first": 1.0, "own": 4.0}
    assert main(["validate", str(tree)]) == 0


@pytest.mark.parametrize(
    ("ref", "written"),
    [
        ("[a.yaml]", "a list"),
        ("''", "empty"),
        ("5", "5 (a number: quote a name)"),
        ("{file: a.yaml}", "a mapping"),
    ],
)
def test_a_ref_that_is_no_name_is_said_so_not_missing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], ref: str, written: str
) -> None:
    tree = tmp_path / "t.yaml"
    tree.write_text(f"root: {{type: subtree, ref: {ref}}}\n")
    assert _validate(capsys, tree) == [
        f"{tree}:1:23: ref: must be a subtree's name, FILE.yaml or FILE.yaml#NAME, not {written}"
    ]


def test_a_value_of_another_kind_than_its_key_s_declaration_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    tree = tmp_path / "t.yaml"
    tree.write_text(
        "blackboard:\n"
        "  label: {type: string, default: '5'}\n"
        "  go: {type: boolean, default: true}\n"
        "  count: {type: integer, default: 1}\n"
        "root:\n"
        "  type: sequence\n"
        "  children:\n"
        "    - {type: check_blackboard, key: label, value: 5}\n"
        "    - type: skip_if\n"
        "      condition: {blackboard: go, value: 1}\n"
        "      child: success\n"
        "    - {type: check_blackboard, key: go, value: 'yes'}\n"
        "    - {type: check_blackboard, key: count, op: '>=', value: true}\n"
        "    - {type: check_blackboard, key: label, value: '5'}\n"  # as declared: fine
        "    - {type: check_blackboard, key: go, op: '!=', value: false}\n"
        "    - {type: check_blackboard, key: count, op: '<', value: 3}\n"
    )
    t = tree
    assert _validate(capsys, tree) == [
        f"{t}:8:7: check_blackboard: value: 5 is a number, but blackboard key 'label' is"
        " declared string (text never equals it; quote it for text)",
        f"{t}:9:7: skip_if: value: 1 is a number, but blackboard key 'go' is declared"
        " boolean (write true or false)",
        f"{t}:12:7: check_blackboard: value: 'yes' is text, but blackboard key 'go' is"
        " declared boolean (write true or false)",
        f"{t}:13:7: check_blackboard: value: true is a boolean, but blackboard key 'count'"
        " is declared integer (write a number)",
    ]


def test_a_blackboard_default_of_another_kind_than_its_type_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    tree = tmp_path / "t.yaml"
    tree.write_text(
        "params:\n"
        "  p: {type: integer, default: 3}\n"
        "blackboard:\n"
        "  go: {type: boolean, default: maybe}\n"
        "  count: {type: integer, default: 1.5}\n"
        "  label: {type: string, default: 5}\n"
        "  gap: {type: number, default: 1 m}\n"
        "  k: {type: integer, default: $p}\n"
        "  fine: {type: number, default: 2}\n"
        "  any: {default: [1, x]}\n"
        "root: success\n"
    )
    t = tree
    assert _validate(capsys, tree) == [
        f"{t}:4:23: default: 'maybe' is not true or false (the key is boolean)",
        f"{t}:5:26: default: 1.5 is not a whole number (the key is integer)",
        f"{t}:6:25: default: 5 is not text (the key is string)",
        f"{t}:7:23: default: '1 m' is not a number (the key is number)",
        f"{t}:8:22: default: '$p' is not a whole number (the key is integer); a default"
        " takes no $parameter",
    ]


def test_set_blackboard_of_another_kind_than_its_key_s_declaration_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    tree = tmp_path / "t.yaml"
    tree.write_text(
        "blackboard:\n"
        "  go: {type: boolean, default: false}\n"
        "  gap: {type: length, default: 1 m}\n"
        "root:\n"
        "  type: sequence\n"
        "  children:\n"
        "    - {type: set_blackboard, key: go, value: 'yes'}\n"
        "    - {type: set_blackboard, key: gap, value: 2 m}\n"
        "    - {type: set_blackboard, key: gap, value: 2 m, unit: length}\n"  # fine
        "    - {type: set_blackboard, key: go, value: true}\n"  # fine
        "    - {type: check_blackboard, key: go, value: true}\n"
    )
    t = tree
    assert _validate(capsys, tree) == [
        f"{t}:7:7: set_blackboard: value: 'yes' is text, but blackboard key 'go' is declared"
        " boolean (write true or false)",
        f"{t}:8:7: set_blackboard: value: '2 m' is text, but blackboard key 'gap' is declared"
        " length (text never equals a number and cannot be ordered with one); give"
        " 'unit: length' to write a quantity",
    ]


def test_a_file_of_another_kind_given_as_a_tree_is_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    network = tmp_path / "net.yaml"
    network.write_text(
        "schema_version: 1\n"
        "diameter: 63 mm\n"
        "start: {segment: a}\n"
        "segments:\n"
        "  - {id: a, kind: straight, length: 2 m}\n"
    )
    tree = tmp_path / "t.yaml"
    tree.write_text("root: {type: subtree, ref: net.yaml}\n")
    said = (
        f"{network}:1:1: not a behaviour tree: it has none of its keys (blackboard, params,"
        " root, subtrees) and keys it does not take (schema_version, diameter, start,"
        " segments): it looks like a pipe network (it has 'segments')"
    )
    assert _validate(capsys, tree) == [said]
    assert main(["validate", "--kind", "tree", str(network)]) == 2
    assert capsys.readouterr().err.strip().splitlines() == [said]


def test_a_drive_s_distance_with_another_until_is_refused_not_ignored(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    tree = tmp_path / "t.yaml"
    tree.write_text(
        "blackboard:\n"
        "  d: {type: length, default: 1 m}\n"
        "root:\n"
        "  type: sequence\n"
        "  children:\n"
        "    - {type: drive, velocity: 80 mm/s, until: blocked, distance: 1 m}\n"
        "    - {type: drive, velocity: 80 mm/s, until: front_opening, distance_key: d}\n"
        "    - {type: drive, velocity: 80 mm/s, distance: 1 m}\n"  # until: distance
        "    - {type: drive, velocity: 80 mm/s, until: blocked, max_distance: 1 m}\n"
    )
    t = tree
    assert _validate(capsys, tree) == [
        f"{t}:6:56: drive: distance: only with until: distance (max_distance bounds a drive"
        " until blocked)",
        f"{t}:7:62: drive: distance_key: only with until: distance (max_distance bounds a"
        " drive until front_opening)",
    ]


def test_an_eternal_guard_condition_that_can_be_running_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    tree = tmp_path / "t.yaml"
    tree.write_text(
        "blackboard:\n"
        "  go: {type: boolean, default: true}\n"
        "root:\n"
        "  type: eternal_guard\n"
        "  conditions:\n"
        "    - {type: check_blackboard, key: go, value: true}\n"
        "    - {type: drive, velocity: 80 mm/s, distance: 0.2 m}\n"
        "    - {type: sequence, name: both, children: [{type: is_clamped, half: rear},"
        " {type: wait, duration: 1 s}]}\n"
        "  child: {type: wait, duration: 3 s}\n"
    )
    t = tree
    said = (
        "can be running: a condition answers success or failure in the tick (once done,"
        " the next tick would start it again); put it in the child"
    )
    assert _validate(capsys, tree) == [
        f"{t}:7:7: eternal_guard: condition 'drive' {said}",
        f"{t}:8:7: eternal_guard: condition 'both' {said}",
    ]


def test_a_subtree_call_that_can_never_run_is_warned_of_where_it_is_called(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    # the warning was placed at the called tree's root (sub.yaml:3:3), a place the
    # author of main.yaml did not write and where nothing is wrong
    (tmp_path / "sub.yaml").write_text(
        "name: sub\nroot:\n  type: sequence\n  name: inner\n  children:\n"
        "    - {type: success, name: ok}\n",
        encoding="utf-8",
    )
    main_yaml = tmp_path / "main.yaml"
    main_yaml.write_text(
        "name: main\nroot:\n  type: sequence\n  name: top\n  children:\n"
        "    - {type: failure, name: never}\n"
        "    - {type: subtree, name: call sub, ref: sub.yaml}\n",
        encoding="utf-8",
    )
    assert main(["validate", str(main_yaml)]) == 0
    said = caplog.text
    assert f"{main_yaml}:7:7: warning: 'call sub' can never run" in said, said


@pytest.mark.parametrize(
    ("merged", "column", "says"),
    [
        ("[1]", 8, "expected a mapping to merge, but found scalar"),
        ("5", 7, "expected a mapping or list of mappings to merge, but found scalar"),
    ],
)
def test_a_merge_key_of_no_mapping_is_said_so_not_a_syntax_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], merged: str, column: int, says: str
) -> None:
    # '<<: [1]' is well-formed YAML; it was reported as a 'YAML syntax error'
    tree = tmp_path / "m.yaml"
    tree.write_text(f"name: m\nroot:\n  <<: {merged}\n  type: success\n", encoding="utf-8")
    assert main(["validate", str(tree)]) == 2
    err = capsys.readouterr().err.strip()
    assert err == f"{tree}:3:{column}: merge key (<<): {says}"
