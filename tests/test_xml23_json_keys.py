"""A ``json:`` object that writes a key twice (docs/interop.md, Values).

Python's JSON reader keeps the last of two values of one key: ``_blackboard='json:{"k":
{"type": "number"}, "k": {"type": "string"}}'`` declared ``k`` a string without a word,
and ``json:{"a": 1, "a": 2}`` in a port was ``{'a': 2}``. A tree file (YAML) refuses a
duplicate key; the XML's JSON now does too, at its element.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.cli import main

_BOARD = (
    '_blackboard="json:{&quot;k&quot;: {&quot;type&quot;: &quot;number&quot;},'
    ' &quot;k&quot;: {&quot;type&quot;: &quot;string&quot;}}"'
)


@pytest.mark.parametrize(
    ("tree", "said"),
    [
        (
            f'<BehaviorTree ID="M" {_BOARD}><success/></BehaviorTree>',
            "t.xml:2:1: _blackboard: bad json: value: duplicate key 'k' in an object",
        ),
        (
            '<BehaviorTree ID="M"><scripted statuses="json:[{&quot;a&quot;: 1,'
            ' &quot;a&quot;: 2}]"/></BehaviorTree>',
            "t.xml:2:22: scripted: statuses: bad json: value: duplicate key 'a' in an object",
        ),
    ],
    ids=["blackboard", "port"],
)
def test_a_key_written_twice_in_json_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], tree: str, said: str
) -> None:
    xml = tmp_path / "t.xml"
    xml.write_text(
        f'<root BTCPP_format="4" main_tree_to_execute="M">\n{tree}\n</root>\n', encoding="utf-8"
    )
    assert main(["validate", str(xml)]) == 2
    assert capsys.readouterr().err.replace(str(xml), "t.xml") == said + "\n"


def test_keys_written_once_are_read_as_before(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    xml = tmp_path / "t.xml"
    xml.write_text(
        '<root BTCPP_format="4" main_tree_to_execute="M">\n<BehaviorTree ID="M"'
        ' _blackboard="json:{&quot;k&quot;: {&quot;type&quot;: &quot;number&quot;,'
        ' &quot;default&quot;: 1}}"><check_blackboard key="k" op="==" value="json:1"/>'
        "</BehaviorTree>\n</root>\n",
        encoding="utf-8",
    )
    assert (main(["validate", str(xml)]), capsys.readouterr().err) == (0, "")
