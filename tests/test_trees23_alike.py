"""Names that look alike but are other text (docs/trees.md, Names that look alike).

Two subtrees of a file named ``turn`` and ``tu`` + U+200B + ``rn`` (a zero-width space),
``a b`` and ``a`` + NBSP + ``b``, or ``café`` composed and decomposed, were both taken:
a ref names one of them, and a reader cannot tell which. Sibling nodes ``grip`` and
``grіp`` (Cyrillic і) were both taken too, and showed as two nodes of one name in the
trace and the diagram (the same text in another Unicode form was already refused). A ref
or node type with a Cyrillic letter was told *did you mean 'wait'?* for ``'wаit'``,
two names that read the same. Parameter names and blackboard keys are ASCII
identifiers, refused otherwise, so none of them can look like another.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.cli import main


def _validate(tmp_path: Path, capsys: pytest.CaptureFixture[str], text: str) -> tuple[int, str]:
    tree = tmp_path / "t.yaml"
    tree.write_text(text, encoding="utf-8")
    code = main(["validate", str(tree)])
    return code, capsys.readouterr().err.replace(str(tree), "t.yaml")


_SUBTREES = (
    "name: t\n"
    "root:\n"
    "  type: sequence\n"
    "  children:\n"
    "    - {{type: subtree, ref: {first}}}\n"
    "    - {{type: subtree, ref: {second}}}\n"
    "subtrees:\n"
    "  {first}: {{root: {{type: wait, duration: 1 s}}}}\n"
    "  {second}: {{root: {{type: wait, duration: 2 s}}}}\n"
)


@pytest.mark.parametrize(
    ("first", "second", "why"),
    [
        ("turn", '"tu\\u200brn"', r"'\u200b' is U+200B ZERO WIDTH SPACE"),
        ('"a b"', '"a\\u00a0b"', r"'\xa0' is U+00A0 NO-BREAK SPACE"),
        ("tarn", "t\u0430rn", "'\u0430' is U+0430 CYRILLIC SMALL LETTER A"),
        ("Tarn", "\u03a4arn", "'\u03a4' is U+03A4 GREEK CAPITAL LETTER TAU"),
        ("caf\u00e9", "cafe\u0301", "the same text in another Unicode form"),
        ("grip", "\uff47rip", "'\uff47' is U+FF47 FULLWIDTH LATIN SMALL LETTER G"),
    ],
    ids=["zero-width", "nbsp", "cyrillic", "greek", "nfd", "fullwidth"],
)
def test_two_subtrees_named_alike_are_refused_naming_both(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], first: str, second: str, why: str
) -> None:
    code, err = _validate(tmp_path, capsys, _SUBTREES.format(first=first, second=second))
    assert code == 2
    (line,) = err.splitlines()
    assert line.startswith("t.yaml:9:3: subtree name ")
    assert f" looks like {first.strip(chr(34))!r} (at t.yaml:8:3: {why}" in line
    assert line.endswith("); a ref could mean either: rename one")


def test_subtrees_that_only_share_letters_of_other_scripts_are_taken(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # Russian and Greek names, and 'Turn' beside 'turn': distinct on a screen
    text = _SUBTREES.format(first="поворот", second="στροφή")
    assert _validate(tmp_path, capsys, text) == (0, "")
    assert _validate(tmp_path, capsys, _SUBTREES.format(first="turn", second="Turn")) == (0, "")


@pytest.mark.parametrize(
    ("second", "why"),
    [
        ("gr\u0456p", "'\u0456' is U+0456 CYRILLIC SMALL LETTER BYELORUSSIAN-UKRAINIAN I"),
        ("\u0261rip", "'\u0261' is U+0261 LATIN SMALL LETTER SCRIPT G"),
    ],
    ids=["cyrillic", "script-g"],
)
def test_sibling_nodes_named_alike_are_a_duplicate(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], second: str, why: str
) -> None:
    text = (
        "name: t\nroot:\n  type: sequence\n  children:\n"
        "    - {type: wait, name: grip, duration: 1 s}\n"
        f"    - {{type: wait, name: {second}, duration: 1 s}}\n"
    )
    code, err = _validate(tmp_path, capsys, text)
    if "SCRIPT G" in why:  # not in the table: a look-alike Unicode does not fold
        assert (code, err) == (0, "")
        return
    assert (code, err) == (
        2,
        f"t.yaml:6:7: duplicate node name {second!r} among siblings (first at t.yaml:5:7)"
        f" (shown alike: {why})\n",
    )


def test_a_did_you_mean_that_reads_the_same_says_which_character_differs(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    text = (
        "name: t\nroot:\n  type: sequence\n  children:\n"
        "    - {type: subtree, ref: t\u0430rn}\n"
        "    - {type: w\u0430it, duration: 1 s}\n"
        "subtrees:\n  tarn: {root: {type: wait, duration: 1 s}}\n"
    )
    code, err = _validate(tmp_path, capsys, text)
    cyrillic_a = "('\u0430' is U+0430 CYRILLIC SMALL LETTER A)"
    assert (code, err.splitlines()) == (
        2,
        [
            f"t.yaml:5:23: no subtree named 't\u0430rn'; did you mean 'tarn'? {cyrillic_a}",
            f"t.yaml:6:8: unknown node type 'w\u0430it'; did you mean 'wait'? {cyrillic_a}",
        ],
    )


def test_bt_cpp_tree_ids_and_node_names_alike_are_refused_at_their_elements(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    xml = tmp_path / "t.xml"
    xml.write_text(
        '<root BTCPP_format="4" main_tree_to_execute="M">\n'
        '<BehaviorTree ID="M"><Sequence><SubTree ID="turn"/><SubTree ID="tu&#x200B;rn"/>'
        '<wait name="grip" duration="1 s"/><wait name="gr&#x456;p" duration="1 s"/>'
        "</Sequence></BehaviorTree>\n"
        '<BehaviorTree ID="turn"><AlwaysSuccess/></BehaviorTree>\n'
        '<BehaviorTree ID="tu&#x200B;rn"><AlwaysSuccess/></BehaviorTree>\n'
        "</root>\n",
        encoding="utf-8",
    )
    assert main(["validate", str(xml)]) == 2
    lines = capsys.readouterr().err.replace(str(xml), "t.xml").splitlines()
    assert lines == [
        "t.xml:2:114: duplicate node name 'gr\u0456p' among siblings (first at t.xml:2:80)"
        " (shown alike: '\u0456' is U+0456 CYRILLIC SMALL LETTER BYELORUSSIAN-UKRAINIAN I)",
        "t.xml:4:1: subtree name 'tu\\u200brn' looks like 'turn' (at t.xml:3:1:"
        " '\\u200b' is U+200B ZERO WIDTH SPACE); a ref could mean either: rename one",
    ]


def test_a_huge_name_folds_to_its_skeleton() -> None:
    from pirate_bt.treefile.names import skeleton

    name = "w" * 2_000_000 + "\u0430" + "\u200b" * 2_000_000
    assert skeleton(name) == "w" * 2_000_000 + "a"
