"""A blackboard key declared with a type that does not exist is refused.

Until 2026-12-01 ``blackboard: {k: {type: nope}}`` validated (and so did a BT.CPP
``_blackboard`` declaring ``"type": "nope"``): the key's default and the comparisons
with it went unchecked, as for a key of no type. It is refused where it is written,
naming the key and the types that exist, with a *did you mean* when one is close
(docs/trees.md, Blackboard).
"""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.cli import main
from pirate_bt.treefile.schema import tree_schema

_TYPES = "any, length, duration, angle"


def _errors(capsys: pytest.CaptureFixture[str], path: Path) -> list[str]:
    assert main(["validate", str(path)]) == 2
    return capsys.readouterr().err.splitlines()


@pytest.mark.parametrize("kind", ["nope", "Length", "lenght", "list"])
def test_a_yaml_key_of_an_unknown_type_is_refused_where_it_is_declared(
    tmp_path: Path, kind: str, capsys: pytest.CaptureFixture[str]
) -> None:
    tree = tmp_path / "t.yaml"
    tree.write_text(
        "blackboard:\n"
        "  ok: {type: length}\n"
        f"  gap: {{type: {kind}, default: 1}}\n"
        "root: {type: check_blackboard, key: gap, op: '>', value: 0}\n",
        encoding="utf-8",
    )
    lines = _errors(capsys, tree)
    assert len(lines) == 1, lines
    assert lines[0].startswith(f"{tree}:3:"), lines
    assert f"blackboard key 'gap': type: {kind!r} is not a blackboard type" in lines[0]
    assert _TYPES in lines[0] and "boolean, string" in lines[0], lines
    if kind.lower() in ("length", "lenght"):
        assert lines[0].endswith("did you mean 'length'?"), lines
    else:
        assert "did you mean" not in lines[0], lines


def test_a_btcpp_blackboard_of_an_unknown_type_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    xml = tmp_path / "t.xml"
    xml.write_text(
        '<root BTCPP_format="4" main_tree_to_execute="t">\n'
        '  <BehaviorTree ID="t" _blackboard=\'json:{"k": {"type": "nope"}}\'>\n'
        "    <AlwaysSuccess/>\n"
        "  </BehaviorTree>\n"
        "</root>\n",
        encoding="utf-8",
    )
    lines = _errors(capsys, xml)
    assert len(lines) == 1, lines
    assert lines[0].startswith(f"{xml}:2:"), lines
    assert "blackboard key 'k': type: 'nope' is not a blackboard type" in lines[0]
    assert _TYPES in lines[0]


def test_every_known_type_is_taken_and_the_schema_lists_them(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    kinds = ["any", "length", "duration", "angle", "number", "integer", "boolean", "string"]
    tree = tmp_path / "t.yaml"
    board = "".join(f"  k_{kind}: {{type: {kind}}}\n" for kind in kinds)
    tree.write_text(f"blackboard:\n{board}root: success\n", encoding="utf-8")
    assert main(["validate", str(tree)]) == 0, capsys.readouterr().err
    decl = tree_schema()["properties"]["blackboard"]["additionalProperties"]
    assert set(kinds) <= set(decl["properties"]["type"]["enum"])
    assert "nope" not in decl["properties"]["type"]["enum"]
