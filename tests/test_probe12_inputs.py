"""Hostile input files that crashed, misplaced or lost what they held (probe 12).

A hostile-input probe on 2026-11-30 found a YAML value whose explicit tag its text does
not fit (``attempts: !!int abc``, ``!!bool 3``, a bare ``!!float``) crashing every file
kind's loader with a raw ``ValueError``, ``KeyError`` or ``IndexError`` (``pirate-bt
validate``: "internal error", exit 1, or the unlocated line ``tree.yaml: 3``), and a
key YAML 1.1 reads as a number or null (``1:``, ``~:``) refused in the validator's
words at the mapping ("Keys should be strings", at 1:1) instead of being its text.
"""

from __future__ import annotations

from pathlib import Path

import pytest

import pirate_bt
from pirate_bt.cli import main
from pirate_bt.errors import ValidationFailed
from pirate_bt.task import parse_route
from pirate_bt.yamlfile import load_yaml_text

# -- explicit YAML tags ----------------------------------------------------------------


@pytest.mark.parametrize(
    ("value", "message"),
    [
        ("!!int abc", "a YAML !!int value is a whole number, not 'abc'"),
        ("!!int", "a YAML !!int value is a whole number, not ''"),
        ("!!int 0b2", "a YAML !!int value is a whole number, not '0b2'"),
        ("!!bool 3", "a YAML !!bool value is true or false, not '3'"),
        ("!!float x", "a YAML !!float value is a number, not 'x'"),
    ],
)
def test_a_tagged_value_its_text_does_not_fit_is_one_located_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], value: str, message: str
) -> None:
    # was "internal error: ValueError: invalid literal for int() ...", exit 1 (and for
    # !!bool the line "tree.yaml: 3"); load_tree raised the bare ValueError or KeyError
    tree = tmp_path / "tree.yaml"
    tree.write_text(f"root: {{type: retry, attempts: {value}, child: success}}\n")
    assert main(["validate", str(tree)]) == 2
    assert capsys.readouterr().err == f"{tree}:1:31: {message}\n"
    with pytest.raises(ValidationFailed) as caught:
        pirate_bt.load_tree(tree)
    assert [str(e) for e in caught.value.errors] == [f"{tree}:1:31: {message}"]


def test_every_file_kind_refuses_a_tagged_value_at_its_place(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    spec = tmp_path / "c.campaign.yaml"
    spec.write_text("name: c\nruns: [{tree: straight, params: {distance: !!float x}}]\n")
    network = tmp_path / "n.yaml"
    network.write_text("segments: !!bool x\n")
    out = tmp_path / "out"
    assert main(["validate", str(spec), str(network)]) == 2
    assert capsys.readouterr().err.splitlines() == [
        f"{spec}:2:44: a YAML !!float value is a number, not 'x'",
        f"{network}:1:11: a YAML !!bool value is true or false, not 'x'",
    ]
    assert main(["campaign", str(spec), "--output", str(out), "--quiet"]) == 2
    assert "!!float" in capsys.readouterr().err
    assert not out.exists()


def test_values_whose_tag_fits_are_read_as_tagged() -> None:
    doc = load_yaml_text('a: [!!int 3, !!float 2, !!bool yes, !!int "7", !!float .5]\n')
    assert doc.data == {"a": [3, 2.0, True, 7, 0.5]}


# -- keys ------------------------------------------------------------------------------


def test_a_key_that_yaml_reads_as_a_number_or_null_is_its_text(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # was "tree.yaml:1:1: success: Keys should be strings" (pydantic's words, at the file's
    # first line); a campaign's the same at its mapping
    doc = load_yaml_text("{1: a, 1.5: b, null: c, ~: d, !!int x: e}\n")
    assert doc.data == {"1": "a", "1.5": "b", "null": "c", "~": "d", "x": "e"}
    tree = tmp_path / "tree.yaml"
    tree.write_text("root: {type: success, 1: x}\n")
    spec = tmp_path / "c.campaign.yaml"
    spec.write_text("name: c\nruns: [{tree: straight, params: {distance: 1 m}, 5: x}]\n")
    assert main(["validate", str(tree), str(spec)]) == 2
    assert capsys.readouterr().err.splitlines() == [
        f"{tree}:1:23: success: unknown key '1'",
        f"{spec}:2:50: unknown key '5'",
    ]
    # one key still, however it is written
    with pytest.raises(ValidationFailed, match=r"1:8: duplicate key '1'"):
        load_yaml_text('{1: a, "1": b}\n', "f.yaml")


# -- line breaks an editor does not show -----------------------------------------------

NOTE = "# a note\x85    - {type: failure}\n"
"""A comment an editor shows on one line; YAML 1.1 read what follows U+0085 as a line of
its own, here a node nobody sees."""


@pytest.mark.parametrize(
    ("text", "place", "char", "label", "escape"),
    [
        # was read: the hidden node made the tree fail; an editor shows one child
        (
            "root:\n  type: sequence\n  children:\n    - success\n    " + NOTE,
            "5:13",
            "0085",
            "a next-line character",
            "\\N",
        ),
        # was 'a b' (folded), and every later place a line off
        ('description: "a\x85b"\nroot: success\n', "1:16", "0085", "a next-line character", "\\N"),
        # was "2:2: YAML syntax error: could not find expected ':'" (a line the editor lacks)
        (
            "x: 1\r\ndescription: a\u2028b\nroot: success\n",
            "2:15",
            "2028",
            "a line separator",
            "\\L",
        ),
    ],
)
def test_a_line_break_an_editor_does_not_show_is_refused_where_it_is(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    text: str,
    place: str,
    char: str,
    label: str,
    escape: str,
) -> None:
    tree = tmp_path / "tree.yaml"
    tree.write_text(text, encoding="utf-8")
    assert main(["validate", "--kind", "tree", str(tree)]) == 2
    assert capsys.readouterr().err == (
        f"{tree}:{place}: U+{char} ({label}) is not allowed in YAML text: a reader takes it"
        f" for a line break, an editor does not; in double-quoted text write {escape}\n"
    )
    # the escape is the character, where an editor shows it
    doc = load_yaml_text(f'd: "a{escape}b"\n')
    assert doc.data == {"d": "a" + chr(int(char, 16)) + "b"}


def test_a_form_feed_in_a_route_comment_is_not_a_command(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # was read as the command 'forward 5 m', on a line an editor shows as a comment
    route = tmp_path / "r.route"
    route.write_text("network straight\n# skip this:\x0cforward 5 m\nforward 1 m\n")
    assert main(["validate", str(route)]) == 2
    assert capsys.readouterr().err == (
        f"{route}:2:13: U+000C (a form feed) is not allowed in route text: a reader takes it"
        " for a line break, an editor does not\n"
    )
    with pytest.raises(ValidationFailed, match=r"U\+000C"):
        pirate_bt.load_route(route)
    # route text given from Python is read the same way (parse_route split it into lines)
    with pytest.raises(ValidationFailed) as caught:
        parse_route(route.read_text(), "typed")
    assert str(caught.value).startswith("typed:2:13: U+000C (a form feed) is not allowed")


def test_an_xml_value_holding_such_a_break_is_imported_escaped(tmp_path: Path) -> None:
    # the converted tree held U+0085 as it was: PyYAML folded it to a space ("a b")
    xml = tmp_path / "t.xml"
    xml.write_text(
        '<root BTCPP_format="4"><BehaviorTree ID="t" _description="d&#x85;e">'
        '<log message="a&#x2028;b&#10;c"/></BehaviorTree></root>'
    )
    out = pirate_bt.import_xml(xml, tmp_path / "t.yaml")
    assert '"d\\Ne"' in out.read_text()
    loaded = pirate_bt.load_xml_tree(xml)
    assert loaded.spec.params.message == "a\u2028b\nc"


# -- long names in messages ------------------------------------------------------------


def test_a_huge_blackboard_key_or_choice_is_cut_short_in_its_message(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # each was written whole: a 5,000-character key made a 5,000-character line
    key, choice = "k" * 5000, "c" * 5000
    tree = tmp_path / "tree.yaml"
    tree.write_text(
        f"params:\n  d: {{type: string, default: left, choices: [{choice}, right]}}\n"
        f"root: {{type: set_blackboard, key: {key}, value: 1}}\n"
    )
    assert main(["validate", str(tree)]) == 2
    lines = capsys.readouterr().err.splitlines()
    assert lines == [
        f"{tree}:2:21: default: expected one of {'c' * 37}..., right, got 'left'",
        f"{tree}:3:1: blackboard key {'k' * 40!r}... (5000 characters) is written but not declared",
    ]


def test_a_list_of_thousands_of_parameters_is_cut_short(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    params = "".join(f"  p{i}: {{type: integer, default: 1}}\n" for i in range(3000))
    tree = tmp_path / "tree.yaml"
    tree.write_text(f"params:\n{params}root: {{type: retry, attempts: $nope, child: success}}\n")
    assert main(["validate", str(tree)]) == 2
    (line,) = capsys.readouterr().err.splitlines()
    assert line.endswith("$p18, $p19, ... (2980 more))") and len(line) < 400


def test_a_huge_module_or_state_value_is_cut_short_in_the_message(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # the bend's module and a guard's state value were written whole: a 3,000-character
    # name made a 3,000-character line
    huge = "x" * 3000
    bend = tmp_path / "bend.yaml"
    bend.write_text(f"name: big\nroot: {{type: bend, name: b, module: {huge}, angle: 40 deg}}\n")
    assert main(["validate", str(bend)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and len(err) < 300, err[:400]
    assert "(3000 characters) is not a bend module or a half" in err
    guard = tmp_path / "guard.yaml"
    guard.write_text(
        "name: g\nroot:\n  type: failure_if\n  name: g\n"
        f"  condition: {{state: half.{huge}, value: clamped}}\n"
        "  child: {type: success, name: ok}\n"
    )
    assert main(["validate", str(guard)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and len(err) < 1500, err[:400]
    assert "unknown state value 'half.xxx" in err and "(3005 characters); use one of" in err


@pytest.mark.parametrize(
    "second",
    [
        "{type: bogus, name: a}",  # a type nobody registered
        "{type: bend, name: a, module: front, angel: 40 deg}",  # a key misspelt
    ],
)
def test_a_duplicate_name_is_said_with_the_siblings_other_problems(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], second: str
) -> None:
    # the second 'a' could not be read, so its name was never compared: only its own
    # problem was said, and the duplicate came up once that was mended
    tree = tmp_path / "dup.yaml"
    tree.write_text(
        "name: dup\nroot:\n  type: sequence\n  name: s\n  children:\n"
        f"    - {{type: success, name: a}}\n    - {second}\n"
    )
    assert main(["validate", str(tree)]) == 2
    err = capsys.readouterr().err
    assert f"{tree}:7:7: duplicate node name 'a' among siblings (first at {tree}:6:7)" in err
    assert len(err.splitlines()) >= 2  # and the sibling's own problem
