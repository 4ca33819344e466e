"""A did-you-mean for a name of millions of characters (a hostile file's node type,
subtree reference or XML tag) indexed the name character by character to compare it
with names of ten: 600 MB for 13 MB. Names too long (or too short) to be alike by
their length alone are no longer compared; the suggestions are the same.
"""

from __future__ import annotations

import difflib
import tracemalloc
from pathlib import Path

import pytest

from pirate_bt.errors import LocatedError, ValidationFailed
from pirate_bt.interop.btcpp import xml_to_tree
from pirate_bt.treefile import load_tree
from pirate_bt.yamlvalidate import close_matches

_BIG = "x" * 2_000_000


def _peak(call: object) -> tuple[str, int]:
    tracemalloc.start()
    try:
        with pytest.raises((ValidationFailed, LocatedError)) as caught:
            call()  # type: ignore[operator]
        return str(caught.value), tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


@pytest.mark.parametrize(
    ("body", "said"),
    [
        (f"{{type: {_BIG}}}", "2:8: unknown node type 'xxxx"),
        (f"{{type: subtree, ref: {_BIG}}}", "2:23: no subtree named 'xxxx"),
    ],
    ids=["type", "ref"],
)
def test_a_huge_unknown_name_in_yaml_is_refused_without_indexing_it(
    tmp_path: Path, body: str, said: str
) -> None:
    tree = tmp_path / "t.yaml"
    tree.write_text(f"name: t\nroot: {body}\n", encoding="utf-8")
    message, peak = _peak(lambda: load_tree(tree))
    assert message.startswith(f"{tree}:{said}") and len(message) < len(str(tree)) + 200
    assert peak < 30 * tree.stat().st_size  # 70 bytes a character before


def test_a_huge_unknown_tag_in_xml_is_refused_without_indexing_it(tmp_path: Path) -> None:
    xml = tmp_path / "t.xml"
    tag = "A" * 60_000  # under the reader's 65,536: the import's own did-you-mean
    xml.write_text(
        '<root BTCPP_format="4" main_tree_to_execute="M">\n'
        f'<BehaviorTree ID="M"><{tag}/></BehaviorTree></root>\n',
        encoding="utf-8",
    )
    message, peak = _peak(lambda: xml_to_tree(xml))
    assert message.startswith(f"{xml}:2:22: unknown node type 'AAAA")
    assert peak < 30 * xml.stat().st_size


@pytest.mark.parametrize(
    ("word", "cutoff"),
    [("sequnce", 0.6), ("wiat", 0.6), ("x", 0.6), ("", 0.6), ("retry_until", 0.7), ("ab", 0.0)],
)
def test_close_matches_says_what_difflib_says(word: str, cutoff: float) -> None:
    known = ["sequence", "selector", "wait", "retry", "x", "", "a" * 40]
    assert close_matches(word, known, n=3, cutoff=cutoff) == difflib.get_close_matches(
        word, known, n=3, cutoff=cutoff
    )
