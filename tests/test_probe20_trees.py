"""Probe 20: hostile tree files, YAML and BehaviorTree.CPP v4 XML (docs/trees.md,
docs/interop.md).

Findings, each with its test below:

- two sibling names that are the same text in two Unicode forms (``café`` with U+00E9,
  and ``cafe`` + U+0301) loaded as two siblings, shown alike in every node path (the
  trace summary showed two rows ``café``), where docs/trees.md refuses names that would
  make two names look alike; and so did two names that differ only by a zero-width
  joiner (``grip`` and ``grip`` + U+200D), which a name may hold for emoji and scripts;
- an XML integer port of 5000 digits (``num_attempts``, ``num_cycles``) was said to be
  *expected an integer*, and a ``json:`` one was said in Python's words (*Exceeds the
  limit (4300 digits) for integer string conversion*); the YAML loader says *a number
  of 5000 digits is too long*, and so do they now;
- a ``parallel`` with ``policy: selected`` whose named children succeed was taken to
  never finish when another child is always running: the node after it was warned of
  as one that *can never run*, while the run ran it and succeeded;
- ``<ReactiveSequence _pirate_bt="bogus">`` was refused as *_pirate_bt='bogus' is only
  known on a <ReactiveSequence>*, which it was on;
- a value of ``$name`` and a line break (``message: "$greeting\\n"``, or a ``|`` block)
  was taken for the parameter, the line break dropped (``$`` of a regular expression
  also matches before a last line break), where ``$name`` and a space is refused as no
  whole value (*write $name, or $$ for a literal $*); export wrote it as ``{greeting}``;
- such a value that is no ``$name`` (``duration: "$d "``, ``attempts: "$ 3"``) was one
  mistake said in two lines, the second checking the text as the node's value (*wait:
  not a quantity: '$d '*), where docs/trees.md promises one line;
- a parameter declared under a name that is a Python identifier but not ASCII
  (``café``) was taken, and every ``$café`` refused as *write $name, or $$ for a literal
  $*, which it was: the declaration is now refused, saying why, and its uses not again;
  an XML pointer ``{café}`` was said in the YAML's words (*'$café': write $name*);
- ``ref: Grip.YAML`` beside a file ``Grip.YAML`` (which ``pirate-bt run`` and
  ``validate`` read as a tree file) was *no subtree named 'Grip.YAML'*, and a subtree
  named ``Grip.YAML`` loaded, exported as a BT.CPP ID that ``import`` took for a name:
  the ``.yaml`` and ``.yml`` endings are now read in any case, as ``.xml`` already was;
- a bad value in ``params=`` given from Python to an XML tree
  (``pirate_bt.load_tree("t.xml", params=...)``, ``simulate_tree``, ``load_xml_tree``,
  ``export_xml``) was said at ``--param:1:1``, an option nobody gave, where a YAML
  tree's is said at the planner's line, as docs/trees.md says.
"""

from __future__ import annotations

import unicodedata
from pathlib import Path
from typing import Any

import pytest

from pirate_bt.cli import main

COMPOSED = unicodedata.normalize("NFC", "café")
DECOMPOSED = unicodedata.normalize("NFD", "café")


def _xml(body: str) -> str:
    return (
        '<?xml version="1.0"?>\n<root BTCPP_format="4" main_tree_to_execute="main">\n'
        f'<BehaviorTree ID="main">{body}</BehaviorTree>\n</root>\n'
    )


@pytest.mark.parametrize("suffix", ["yaml", "xml"])
def test_two_sibling_names_that_differ_only_in_unicode_form_are_a_duplicate(
    tmp_path: Path, capsys: Any, suffix: str
) -> None:
    assert COMPOSED != DECOMPOSED
    tree = tmp_path / f"t.{suffix}"
    if suffix == "yaml":
        tree.write_text(
            "root:\n  type: sequence\n  children:\n"
            f"    - {{type: success, name: {COMPOSED}}}\n"
            f"    - {{type: success, name: {DECOMPOSED}}}\n",
            encoding="utf-8",
        )
        place = "5:7"
    else:
        tree.write_text(
            _xml(
                f'<Sequence><AlwaysSuccess name="{COMPOSED}"/>'
                f'<AlwaysSuccess name="{DECOMPOSED}"/></Sequence>'
            ),
            encoding="utf-8",
        )
        place = "3:63"
    assert main(["validate", str(tree)]) == 2
    err = capsys.readouterr().err.strip()
    assert f"t.{suffix}:{place}: duplicate node name" in err
    assert "another Unicode form" in err
    assert len(err.splitlines()) == 1


def test_the_same_name_twice_in_one_form_is_said_as_before(tmp_path: Path, capsys: Any) -> None:
    tree = tmp_path / "t.yaml"
    tree.write_text(
        "root:\n  type: sequence\n  children:\n"
        f"    - {{type: success, name: {DECOMPOSED}}}\n"
        f"    - {{type: success, name: {DECOMPOSED}}}\n",
        encoding="utf-8",
    )
    assert main(["validate", str(tree)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.endswith(":4:7)"), err
    assert "Unicode form" not in err


@pytest.mark.parametrize(
    ("element", "said"),
    [
        (
            '<RetryUntilSuccessful num_attempts="{n}"><AlwaysSuccess/></RetryUntilSuccessful>',
            "num_attempts: a number of 5000 digits is too long",
        ),
        (
            '<Repeat num_cycles="{n}"><AlwaysSuccess/></Repeat>',
            "num_cycles: a number of 5000 digits is too long",
        ),
        (
            '<check_blackboard key="k" op="==" value="json:{n}"/>',
            "value: bad json: value: a number of 5000 digits is too long",
        ),
    ],
)
def test_an_xml_integer_too_long_to_read_is_said_to_be_too_long(
    tmp_path: Path, capsys: Any, element: str, said: str
) -> None:
    tree = tmp_path / "t.xml"
    tree.write_text(_xml(element.replace("{n}", "9" * 5000)), encoding="utf-8")
    assert main(["validate", str(tree)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.endswith(said), err
    assert "expected an integer" not in err and "4300" not in err


def test_a_parallel_that_succeeds_on_its_selected_children_lets_the_next_one_run() -> None:
    from pirate_bt.treefile import load_tree

    def tree(selected: list[str]) -> dict[str, Any]:
        return {
            "root": {
                "type": "sequence",
                "children": [
                    {
                        "type": "parallel",
                        "policy": "selected",
                        "selected": selected,
                        "children": [
                            {"type": "success", "name": "done"},
                            {"type": "running", "name": "spin"},
                        ],
                    },
                    {"type": "log", "name": "after", "message": "past the parallel"},
                ],
            }
        }

    assert load_tree(tree(["done"])).warnings == []
    waiting = [w.message for w in load_tree(tree(["spin"])).warnings]
    assert waiting == [
        "warning: 'after' can never run: 'parallel' before it in sequence 'sequence' never finishes"
    ]


def test_an_unknown_pirate_bt_mark_on_a_reactive_sequence_is_said_so(
    tmp_path: Path, capsys: Any
) -> None:
    tree = tmp_path / "t.xml"
    tree.write_text(
        _xml(
            '<ReactiveSequence _pirate_bt="guard"><AlwaysSuccess/><AlwaysSuccess/>'
            "</ReactiveSequence>"
        ),
        encoding="utf-8",
    )
    assert main(["validate", str(tree)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.endswith(
        "t.xml:3:25: _pirate_bt='guard' is not known:"
        ' pirate_bt writes only _pirate_bt="eternal_guard"'
    ), err
    tree.write_text(
        _xml('<Sequence _pirate_bt="eternal_guard"><AlwaysSuccess/></Sequence>'),
        encoding="utf-8",
    )
    assert main(["validate", str(tree)]) == 2
    assert (
        capsys.readouterr()
        .err.strip()
        .endswith("t.xml:3:25: _pirate_bt='eternal_guard' is only known on a <ReactiveSequence>")
    )


@pytest.mark.parametrize("value", ['"$greeting\\n"', "|\n      $greeting"])
def test_a_parameter_and_a_line_break_is_no_whole_value(
    tmp_path: Path, capsys: Any, value: str
) -> None:
    tree = tmp_path / "t.yaml"
    tree.write_text(
        "params:\n  greeting: {type: string, default: hi}\n"
        f"root:\n  type: log\n  message: {value}\n",
        encoding="utf-8",
    )
    assert main(["validate", str(tree)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.endswith("t.yaml:5:3: '$greeting\\n': write $name, or $$ for a literal $"), err
    assert main(["export", "btcpp", str(tree), "-o", str(tmp_path / "t.xml")]) == 2
    assert not (tmp_path / "t.xml").exists()


@pytest.mark.parametrize(
    ("node", "said"),
    [
        ('{type: wait, duration: "$d "}', "'$d ': write $name, or $$ for a literal $"),
        ('{type: retry, attempts: "$ 3", child: success}', "'$ 3': write $name, or $$"),
    ],
)
def test_a_dollar_that_names_no_parameter_is_one_line(
    tmp_path: Path, capsys: Any, node: str, said: str
) -> None:
    tree = tmp_path / "t.yaml"
    tree.write_text(f"params:\n  d: {{type: duration, default: 1 s}}\nroot: {node}\n")
    assert main(["validate", str(tree)]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1, lines
    assert said in lines[0]


@pytest.mark.parametrize("suffix", ["yaml", "xml"])
def test_a_parameter_name_no_dollar_can_name_is_refused_where_declared(
    tmp_path: Path, capsys: Any, suffix: str
) -> None:
    tree = tmp_path / f"t.{suffix}"
    if suffix == "yaml":
        tree.write_text(
            "params:\n  café: {type: string, default: x}\nroot: {type: log, message: $café}\n",
            encoding="utf-8",
        )
        place = "2:3"
    else:
        tree.write_text(
            _xml('<SubTree ID="a" café="x"/>').replace(
                "</root>",
                '<BehaviorTree ID="a"><AlwaysSuccess/></BehaviorTree>'
                '<TreeNodesModel><SubTree ID="a"><input_port name="café" type="string"/>'
                "</SubTree></TreeNodesModel></root>",
            ),
            encoding="utf-8",
        )
        place = "4:85"
    assert main(["validate", str(tree)]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1, lines
    assert lines[0].endswith(
        f"t.{suffix}:{place}: parameter name 'café' must be an identifier"
        " of ASCII letters, digits and '_', as $name is written"
        " ('é' is U+00E9 LATIN SMALL LETTER E WITH ACUTE)"
    ), lines


def test_an_xml_pointer_no_parameter_can_be_is_said_in_the_xml_s_words(
    tmp_path: Path, capsys: Any
) -> None:
    tree = tmp_path / "t.xml"
    tree.write_text(_xml('<log message="{café}"/>'), encoding="utf-8")
    assert main(["validate", str(tree)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.endswith(
        "t.xml:3:25: log: message: blackboard pointer '{café}': pirate_bt parameters are"
        " identifiers of ASCII letters, digits and '_'"
    ), err


def test_a_yaml_ending_in_capitals_names_a_file_in_a_ref(tmp_path: Path, capsys: Any) -> None:
    (tmp_path / "Grip.YAML").write_text("root: {type: log, name: grip, message: g}\n")
    tree = tmp_path / "t.yaml"
    tree.write_text("root: {type: subtree, ref: Grip.YAML}\n")
    assert main(["validate", str(tree)]) == 0
    out = tmp_path / "t.xml"
    assert main(["export", "btcpp", str(tree), "-o", str(out)]) == 0
    back = tmp_path / "back.yaml"
    assert main(["import", "btcpp", str(out), "-o", str(back)]) == 0
    assert main(["run", str(back), "--quiet"]) == 0
    capsys.readouterr()
    tree.write_text("root: {type: subtree, ref: x}\nsubtrees:\n  x.YML: {root: success}\n")
    assert main(["validate", str(tree)]) == 2
    assert "t.yaml:3:3: subtree name 'x.YML': no ref can name it" in capsys.readouterr().err
    out.write_text(
        _xml('<SubTree ID="x.Yaml"/>').replace(
            "</root>", '<BehaviorTree ID="x.Yaml"><AlwaysSuccess/></BehaviorTree></root>'
        )
    )
    assert main(["validate", str(out)]) == 2
    assert "tree ID 'x.Yaml' would read as a file" in capsys.readouterr().err


def test_a_bad_param_given_to_an_xml_tree_from_python_is_at_the_caller_s_line(
    tmp_path: Path,
) -> None:
    import pirate_bt
    from pirate_bt.errors import ValidationFailed
    from pirate_bt.interop.btcpp import export_xml

    tree = Path(__file__).resolve().parents[1] / "trees" / "straight.yaml"
    xml = tmp_path / "t.xml"
    assert main(["export", "btcpp", "straight", "-o", str(xml), "--param", "distance=1m"]) == 0
    calls = [
        lambda: pirate_bt.load_tree(xml, params={"distance": "9 deg"}),
        lambda: pirate_bt.load_xml_tree(xml, params={"distance": "9 deg"}),
        lambda: export_xml(tree, tmp_path / "o.xml", params={"distance": "9 deg"}),
    ]
    for call in calls:
        with pytest.raises(ValidationFailed) as caught:
            call()
        where = caught.value.errors[0].location
        assert Path(where.file).name == "test_probe20_trees.py", str(caught.value)
        assert where.line > 1


def test_two_sibling_names_that_differ_only_by_a_joiner_are_a_duplicate(
    tmp_path: Path, capsys: Any
) -> None:
    tree = tmp_path / "t.yaml"
    tree.write_text(
        "root:\n  type: sequence\n  children:\n"
        "    - {type: success, name: grip}\n"
        '    - {type: success, name: "grip\\u200d"}\n'
        '    - {type: success, name: "\U0001f468\\u200d\U0001f469"}\n',
        encoding="utf-8",
    )
    assert main(["validate", str(tree)]) == 2
    err = capsys.readouterr().err.strip()
    assert "t.yaml:5:7: duplicate node name 'grip\\u200d' among siblings" in err
    assert err.endswith(":4:7) (the same text but for a zero-width joiner, U+200C or U+200D)")
    assert len(err.splitlines()) == 1


def test_the_tree_schema_names_what_a_parameter_s_name_may_be() -> None:
    import re

    from pirate_bt.treefile import tree_schema

    pattern = tree_schema()["properties"]["params"]["propertyNames"]["pattern"]
    assert re.search(pattern, "roll") and re.search(pattern, "_x2")
    assert not re.search(pattern, "café") and not re.search(pattern, "2x")
