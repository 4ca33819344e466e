"""Located YAML loading."""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.errors import ValidationFailed
from pirate_bt.yamlfile import load_yaml, load_yaml_text


def test_locates_nested_values_and_falls_back_to_parents() -> None:
    doc = load_yaml_text("a: 1\nb:\n  - x: 2\n    y: 3\n", "f.yaml")
    assert doc.data == {"a": 1, "b": [{"x": 2, "y": 3}]}
    assert str(doc.locator.locate(("b", 0, "y"))) == "f.yaml:4:5"
    assert str(doc.locator.locate(("b", 0, "missing"))) == "f.yaml:3:5"


def test_merge_keys_are_not_duplicates() -> None:
    doc = load_yaml_text("base: &b {x: 1, y: 2}\nitem: {<<: *b, y: 3}\n")
    assert doc.data["item"] == {"x": 1, "y": 3}


@pytest.mark.parametrize(
    ("text", "where", "message"),
    [
        ("a: 1\na: 2\n", ":2:1:", "duplicate key 'a' (first written on line 1)"),
        ("a: [1,\n", ":1:7:", "YAML syntax error"),  # at its end, not past the file
        ("", ":1:1:", "file is empty"),
        ("a: b: c\n", ":1:5:", "mapping values are not allowed"),
    ],
)
def test_bad_text_is_located(text: str, where: str, message: str) -> None:
    with pytest.raises(ValidationFailed) as info:
        load_yaml_text(text, "f.yaml")
    assert where in str(info.value) and message in str(info.value)


def test_missing_file(tmp_path: Path) -> None:
    with pytest.raises(ValidationFailed, match="no such file"):
        load_yaml(tmp_path / "nope.yaml")


@pytest.mark.parametrize(
    ("text", "where", "code"),
    [
        ('name: t\nroot: {type: wait, name: "w\x1b", duration: 1 s}\n', "f.yaml:2:28", "U+001B"),
        # libyaml counts the position in bytes: the column is the character's
        ('name: tüü\nroot: {name: "wé\x07"}\n', "f.yaml:2:17", "U+0007"),
        ("a: 1\x7f\n", "f.yaml:1:5", "U+007F"),
    ],
)
def test_a_control_character_is_one_line_at_its_place(text: str, where: str, code: str) -> None:
    # was "f.yaml:1:1: YAML error: unacceptable character ..." and a second line naming
    # PyYAML's "<unicode string>"
    with pytest.raises(ValidationFailed) as err:
        load_yaml_text(text, "f.yaml")
    message = str(err.value)
    assert "\n" not in message
    assert (
        message
        == f"{where}: YAML syntax error: {code} (a control character) is not allowed in YAML"
    )


def test_keys_that_yaml_1_1_reads_as_booleans_are_their_text() -> None:
    # a bare `on:` key was the boolean True (`oneshot: Keys should be strings`);
    # PyYAML reads y and n as text already
    doc = load_yaml_text("on: 1\noff: 2\nyes: no\nNo: true\ny: on\n'true': 3\n", "f.yaml")
    assert doc.data == {"on": 1, "off": 2, "yes": False, "No": True, "y": True, "true": 3}
    assert all(type(key) is str for key in doc.data)
    assert str(doc.locator.locate(("y",))) == "f.yaml:5:1"
    # an anchored key used as a value elsewhere: the value keeps its meaning
    shared = load_yaml_text("a: {&k on: 1}\nb: *k\n")
    assert shared.data == {"a": {"on": 1}, "b": True}
    with pytest.raises(ValidationFailed, match="duplicate key 'on'"):
        load_yaml_text("on: 1\non: 2\n")


def test_oneshot_on_success_written_as_documented(tmp_path: Path) -> None:
    from py_trees.common import OneShotPolicy

    from pirate_bt.treefile import load_tree

    tree = tmp_path / "t.yaml"
    tree.write_text(
        "name: t\nroot:\n  type: oneshot\n  on: success\n  child: {type: log, message: hi}\n",
        encoding="utf-8",
    )
    assert load_tree(tree).root.policy == OneShotPolicy.ON_SUCCESSFUL_COMPLETION  # type: ignore[attr-defined]


def test_a_union_chosen_by_a_key_speaks_of_that_key(tmp_path: Path) -> None:
    # a pipe network's pieces are tagged by `type` (pydantic's discriminator)
    from pirate_bt.pipes.loader import load_network

    good = (Path(__file__).resolve().parent.parent / "scenarios" / "straight.yaml").read_text()
    for old, new, expected in (
        ("type: straight", "type: wiggle", ":9:15: type: 'wiggle' is not one of straight, bend, "),
        ("type: straight", "type: 5", ":9:15: type: 5 is not one of straight, bend, "),
        ("type: straight, ", "", ":9:5: missing required key 'type'"),
    ):
        path = tmp_path / "net.yaml"
        path.write_text(good.replace(old, new), encoding="utf-8")
        with pytest.raises(ValidationFailed) as err:
            load_network(path)
        assert expected in str(err.value), str(err.value)
        assert "discriminator" not in str(err.value) and "\n" not in str(err.value)


@pytest.mark.parametrize("end", ["", "\n"])
def test_a_file_cut_short_is_located_at_its_last_line(end: str) -> None:
    # libyaml marks the end of a file past its last line: '3:1' for a 2-line file
    with pytest.raises(ValidationFailed) as err:
        load_yaml_text("name: t\nroot: {type: wait, name: [" + end, "f.yaml")
    assert str(err.value).startswith("f.yaml:2:27: YAML syntax error: "), str(err.value)


def test_a_named_pipe_is_refused_before_it_is_opened(tmp_path: Path) -> None:
    # Opening a pipe nobody writes to waits for ever: `validate fifo.yaml` hung.
    import os

    from pirate_bt.task.route import load_route

    pipe = tmp_path / "tree.yaml"
    os.mkfifo(pipe)
    with pytest.raises(ValidationFailed, match=r"tree\.yaml:1:1: is a named pipe, not a file"):
        load_yaml(pipe)
    route = tmp_path / "mission.route"
    os.mkfifo(route)
    with pytest.raises(ValidationFailed, match=r"mission\.route:1:1: is a named pipe"):
        load_route(route)


def test_a_refused_value_an_alias_repeats_is_said_once(tmp_path: Path) -> None:
    # `attempts: &a 010` then `name: *a`: the same line twice, at the same place
    path = tmp_path / "alias.yaml"
    path.write_text("a: &n 010\nb: *n\nc: [*n, *n]\n", encoding="utf-8")
    with pytest.raises(ValidationFailed) as caught:
        load_yaml(path)
    assert [str(e) for e in caught.value.errors] == [
        f"{path}:1:4: 010 has a leading zero, which YAML 1.1 reads as an octal number (8):"
        " write 10, or quote it for text"
    ]
