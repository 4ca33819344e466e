"""Three leftovers of the thirteenth session's API work; each test failed before its fix.

1. A tree name that is neither a file nor a bundled tree said ``nosuch:1:1: no such
   file``, naming none of the trees one can use, from the API and ``pirate-bt run``.
2. A campaign run whose tree is BehaviorTree.CPP XML was refused as "not a YAML tree
   file" when its spec was checked, good XML or bad, at the XML's first line only;
   now it is read as ``simulate_tree`` reads it, and a bad one is placed at the spec's
   ``tree`` entry with the XML's own place, in one line.
3. A tree given as a mapping with a key that is not text said pydantic's words
   (``wait: Keys should be strings``), naming neither the node nor the key.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

import pirate_bt
from pirate_bt.campaign import campaign_from_data
from pirate_bt.cli import main
from pirate_bt.errors import InputError, ValidationFailed

BUNDLED = "bend, bend-back, probe-tee, probe-turn, straight, t-joint, t-joint-back"
NO_SUCH = f"nosuch:1:1: no such tree file; bundled trees: {BUNDLED}"


# -- 1. no such tree: the bundled trees are named


def test_the_bundled_trees_are_the_top_level_yaml_files() -> None:
    from pirate_bt.resources import bundled_names

    assert ", ".join(bundled_names("trees")) == BUNDLED  # not lib/ or examples/


@pytest.mark.parametrize("call", [pirate_bt.simulate_tree, pirate_bt.load_tree])
def test_a_tree_that_is_neither_a_file_nor_bundled_names_the_bundled_ones(
    call: Any, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ValidationFailed) as caught:
        call("nosuch")
    assert str(caught.value) == NO_SUCH  # one line
    with pytest.raises(ValidationFailed) as caught:
        call("nosuch.xml")  # an XML name too: it was the XML reader's "no such file"
    assert str(caught.value).startswith("nosuch.xml:1:1: no such tree file; bundled trees: bend")


def test_a_bundled_name_and_a_file_still_load(tmp_path: Path) -> None:
    assert pirate_bt.load_tree("straight", params={"distance": "1 m"}).name == "straight"
    own = tmp_path / "mine.yaml"
    own.write_text("root: {type: wait, duration: 0.1 s}\n", encoding="utf-8")
    assert pirate_bt.simulate_tree(str(own)).succeeded


def test_the_command_line_says_what_the_api_says(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(tmp_path)
    assert main(["run", "nosuch"]) == 2
    assert capsys.readouterr().err == f"pirate-bt: {NO_SUCH}\n"


# -- 2. a campaign's BehaviorTree.CPP XML tree


def _xml(tmp_path: Path, name: str, body: str) -> Path:
    path = tmp_path / name
    path.write_text(f'<root BTCPP_format="4">\n  <BehaviorTree ID="Main">\n{body}', "utf-8")
    return path


def _spec(tmp_path: Path, tree: str, params: str = "") -> Path:
    spec = tmp_path / "x.campaign.yaml"
    spec.write_text(
        f"name: x\nruns:\n  - {{name: a, tree: {tree}{params}}}\nseeds: {{start: 0, count: 1}}\n",
        encoding="utf-8",
    )
    return spec


UNKNOWN_NODE = "    <Sequence>\n      <NoSuchNode/>\n    </Sequence>\n  </BehaviorTree>\n</root>\n"


@pytest.mark.parametrize(
    ("body", "problem"),
    [
        (UNKNOWN_NODE, "unknown node type 'NoSuchNode' (at {xml}:4:7)"),
        ("    <Sequence>\n", "not well-formed XML: no element found (at {xml}:4:1)"),
    ],
)
def test_a_bad_xml_tree_is_placed_at_the_spec_entry_and_in_the_xml(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], body: str, problem: str
) -> None:
    xml = _xml(tmp_path, "bad.xml", body)
    spec = _spec(tmp_path, "bad.xml")
    line = f"{spec}:3:15: run 'a': tree 'bad.xml': {problem.format(xml=xml)}"
    with pytest.raises(InputError) as caught:
        pirate_bt.run_campaign(str(spec), output=tmp_path / "out")
    assert str(caught.value) == line  # was "{xml}:1:1: a BehaviorTree.CPP XML tree, not..."
    assert not (tmp_path / "out").exists()  # refused before any case
    assert main(["validate", str(spec)]) == 2
    seen = capsys.readouterr()
    assert line in (seen.out + seen.err).splitlines()


def test_a_good_xml_tree_runs_in_a_campaign(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["export", "btcpp", "straight", "-o", str(tmp_path / "good.xml")]) == 0
    spec = _spec(tmp_path, "good.xml", ", params: {distance: 0.1 m}")
    assert main(["validate", str(spec)]) == 0
    capsys.readouterr()
    result = pirate_bt.run_campaign(str(spec), output=tmp_path / "out", workers=1, progress=False)
    assert [row["outcome"] for row in result.rows] == ["success"], result.rows
    # a parameter of the XML tree is still placed at its own key in the spec
    bad = _spec(tmp_path, "good.xml", ", params: {distance: abc}")
    with pytest.raises(InputError, match=r"x\.campaign\.yaml:3:40: parameter 'distance': "):
        pirate_bt.run_campaign(str(bad), output=tmp_path / "out2")


# -- 3. a mapping's key that is not text, in the library's words

WAIT = {"type": "wait", "name": "w", "duration": "0.1 s"}


@pytest.mark.parametrize(
    ("tree", "message"),
    [
        ({"root": {**WAIT, 5: "x"}}, "wait 'w': key 5 must be text"),
        ({"root": {**WAIT, None: "x"}}, "wait 'w': key None must be text"),
        (
            {"root": {"type": "sequence", "children": [WAIT, {"type": "success", 7: 1}]}},
            "success at root.children[1]: key 7 must be text",
        ),
        (
            {"root": {"type": "sequence", "name": "s", "children": [WAIT], 5: "x"}},
            "sequence 's': key 5 must be text; allowed: children, memory",
        ),
        (
            {"root": {"type": "failure_if", "name": "f", "condition": {5: 1}, "child": WAIT}},
            "failure_if 'f': condition: key 5 must be text",
        ),
        (
            {"params": {"p": {"type": "number", "default": 1, 9: 2}}, "root": WAIT},
            "parameter 'p': key 9 must be text",
        ),
        (
            {"blackboard": {"k": {"type": "number", 9: 2}}, "root": WAIT},
            "blackboard key 'k': key 9 must be text",
        ),
        (
            {
                "root": {"type": "subtree", "name": "st", "ref": "x", "params": {5: 1}},
                "subtrees": {"x": {"root": WAIT}},
            },
            "subtree 'st': params: key 5 must be text",
        ),
        (
            {
                "root": {"type": "subtree", "name": "st", "ref": "x"},
                "subtrees": {"x": {"root": WAIT, 5: 1}},
            },
            "subtree 'x': key 5 must be text; allowed: description, params, root",
        ),
    ],
)
def test_a_key_that_is_not_text_names_its_node_and_the_key(tree: Any, message: str) -> None:
    with pytest.raises(ValidationFailed) as caught:
        pirate_bt.simulate_tree(tree)  # the call
    said = [e.message for e in caught.value.errors]
    assert said[0] == message, said
    assert not any("should be strings" in m or "Input should" in m for m in said)
    assert caught.value.errors[0].location.file.endswith("test_api_leftovers13.py")


def test_the_briefs_own_example_is_said_in_the_librarys_words() -> None:
    tree = {"type": "sequence", "children": [WAIT], 5: "x"}  # a node where a tree goes
    with pytest.raises(ValidationFailed) as caught:
        pirate_bt.simulate_tree(tree)
    said = [e.message for e in caught.value.errors]
    assert (
        "key 5 must be text; allowed: blackboard, description, name, params, root, subtrees" in said
    )


@pytest.mark.parametrize(
    ("data", "message"),
    [
        ({"runs": [{"tree": "bend", "params": {5: "x"}}]}, "runs[0].params: key 5 must be text"),
        ({"runs": [{"tree": "bend", 7: 1}]}, "runs[0]: key 7 must be text"),
        ({"runs": [{"tree": "bend"}], 3: 1}, "key 3 must be text"),
    ],
)
def test_other_mappings_from_python_say_it_alike(data: dict[Any, Any], message: str) -> None:
    # pydantic's "Keys should be strings" and "Input should be a valid string" (a key of
    # a mapping of text keys, said as 'params: should be text') in every model
    with pytest.raises(InputError) as caught:
        campaign_from_data({"name": "c", **data})
    assert str(caught.value) == f"campaign spec: {message}"
