"""A tab or line break written as itself in an attribute value (a multi-line
``_description``, as Groot2 and BT.CPP's own writer save one): XML's rules, and so
expat, make each a space; BT.CPP's parser (tinyxml2) keeps it, a CR LF or a lone CR
as LF. Import read ``first<LF><TAB>second`` as ``first  second``; it reads what BT.CPP
reads (docs/interop.md, Values).
"""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.interop.btcpp import xml_to_tree

_FILE = (
    '<root BTCPP_format="4" main_tree_to_execute="M">\n'
    '<BehaviorTree ID="M"><Sequence name="s" _description="first\n\tsecond\r\nthird'
    ' &amp; &#9;x\rlast"><log message=\'a\tb\' name="n  m"/><wait duration="1 s"/>'
    "</Sequence></BehaviorTree></root>\n"
)


@pytest.mark.parametrize("encoding", ["utf-8", "utf-16", "iso-8859-1"])
def test_a_tab_or_line_break_written_in_a_value_is_kept_as_bt_cpp_keeps_it(
    tmp_path: Path, encoding: str
) -> None:
    xml = tmp_path / "t.xml"
    head = "" if encoding == "utf-16" else f'<?xml version="1.0" encoding="{encoding}"?>\n'
    xml.write_bytes((head + _FILE).encode(encoding))
    root = xml_to_tree(xml)["root"]
    assert root["description"] == "first\n\tsecond\nthird & \tx\nlast"
    assert root["children"][0] == {"type": "log", "name": "n  m", "message": "a\tb"}
    assert root["children"][1] == {"type": "wait", "duration": "1 s"}
