"""What one element of a BehaviorTree.CPP file may hold (docs/interop.md, Limits): a
name, an attribute value or an element's text of at most MAX_XML_VALUE characters, a
tag or comment of at most MAX_XML_TOKEN bytes. One 13 MB attribute in a file under the
16 MiB cap was read whole (hundreds of MB, a minute or more) and then imported, or
refused only after; a text of many ``&amp;`` was gathered in quadratic time.
"""

from __future__ import annotations

import tracemalloc
from pathlib import Path

import pytest

from pirate_bt.cli import main
from pirate_bt.errors import LocatedError
from pirate_bt.interop.btcpp import xml_to_tree
from pirate_bt.interop.btcpp_xml import MAX_XML_TOKEN, MAX_XML_VALUE

_HEAD = '<root BTCPP_format="4" main_tree_to_execute="M">\n<BehaviorTree ID="M">'
_TAIL = "</BehaviorTree>\n</root>\n"


def _write(tmp_path: Path, body: str) -> Path:
    xml = tmp_path / "t.xml"
    xml.write_text(_HEAD + body + _TAIL, encoding="utf-8")
    return xml


def _refused(xml: Path) -> str:
    with pytest.raises(LocatedError) as caught:
        xml_to_tree(xml)
    return str(caught.value)


_OVER = f", more than the {MAX_XML_VALUE} an XML name, value or text may have"


@pytest.mark.parametrize(
    ("body", "said"),
    [
        (
            '<AlwaysSuccess _description="' + "d" * (MAX_XML_VALUE + 1) + '"/>',
            f"<AlwaysSuccess> _description: a value of {MAX_XML_VALUE + 1} characters{_OVER}",
        ),
        (
            "<" + "A" * (MAX_XML_VALUE + 1) + "/>",
            f"a tag name of {MAX_XML_VALUE + 1} characters{_OVER}",
        ),
        (
            "<AlwaysSuccess " + "k" * (MAX_XML_VALUE + 1) + '="1"/>',
            f"<AlwaysSuccess>: an attribute name of {MAX_XML_VALUE + 1} characters{_OVER}",
        ),
    ],
    ids=["value", "tag", "attribute"],
)
def test_a_name_or_value_over_the_limit_is_refused_at_its_element(
    tmp_path: Path, body: str, said: str
) -> None:
    xml = _write(tmp_path, body)
    assert _refused(xml) == f"{xml}:2:22: {said}"


def test_a_value_at_the_limit_is_read(tmp_path: Path) -> None:
    xml = _write(tmp_path, '<AlwaysSuccess _description="' + "d" * MAX_XML_VALUE + '"/>')
    assert xml_to_tree(xml)["root"]["description"] == "d" * MAX_XML_VALUE


def test_a_text_of_many_entities_is_refused_past_the_limit(tmp_path: Path) -> None:
    # gathered one '&' at a time by 'text +=' (quadratic), then kept whole
    xml = _write(tmp_path, "<AlwaysSuccess/>" + "&amp;" * (MAX_XML_VALUE + 10))
    assert _refused(xml) == (
        f"{xml}:2:1: <BehaviorTree>: more than {MAX_XML_VALUE} characters of text"
        " (the most an XML name, value or text may have)"
    )


@pytest.mark.parametrize(
    ("body", "what", "place"),
    [
        ('<AlwaysSuccess name="' + "x" * 3_000_000 + '"/>', "a tag", "2:22"),
        ("<!-- " + "c" * 3_000_000 + " --><AlwaysSuccess/>", "a comment", "2:22"),
    ],
    ids=["attribute", "comment"],
)
def test_a_huge_tag_or_comment_is_refused_before_it_is_held_whole(
    tmp_path: Path, body: str, what: str, place: str
) -> None:
    xml = _write(tmp_path, body)
    tracemalloc.start()
    try:
        said = _refused(xml)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert said == (
        f"{xml}:{place}: {what} still not closed after {MAX_XML_TOKEN} bytes"
        " (the most one may have)"
    )
    # the file (3 MB) and what expat holds of the tag, not copies of the attribute
    assert peak < 4 * xml.stat().st_size


def test_the_command_line_says_it_in_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    xml = _write(tmp_path, '<AlwaysSuccess name="' + "x" * (2 * MAX_XML_TOKEN) + '"/>')
    assert main(["import", "btcpp", str(xml), "-o", str(tmp_path / "t.yaml")]) == 2
    assert capsys.readouterr().err == (
        f"pirate-bt: {xml}:2:22: a tag still not closed after {MAX_XML_TOKEN} bytes"
        " (the most one may have)\n"
    )
    assert not (tmp_path / "t.yaml").exists()


def test_a_huge_comment_in_utf16_is_named_a_comment(tmp_path: Path) -> None:
    # what is held was named from its first bytes, which in UTF-16 hold NULs: 'a tag'
    xml = tmp_path / "t.xml"
    text = _HEAD + "<!-- " + "c" * MAX_XML_TOKEN + " --><AlwaysSuccess/>" + _TAIL
    xml.write_bytes(text.encode("utf-16"))
    assert _refused(xml) == (
        f"{xml}:2:22: a comment still not closed after {MAX_XML_TOKEN} bytes"
        " (the most one may have)"
    )


def test_the_indentation_between_many_children_is_no_text_over_the_limit(
    tmp_path: Path,
) -> None:
    # 19ead77 counted it: a <Sequence> of 7,300 indented children was refused as
    # 'more than 65536 characters of text'
    children = "".join(f'\n        <wait name="w{i}" duration="1 s"/>' for i in range(8000))
    xml = _write(tmp_path, f"\n    <Sequence>{children}\n    </Sequence>\n")
    assert len(xml_to_tree(xml)["root"]["children"]) == 8000
