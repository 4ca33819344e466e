"""A port's text starting with ``$`` shown as the XML wrote it (docs/interop.md, Values).

The XML's ``$x`` is the text ``$x`` (a pointer is ``{x}``); the tree file the import
writes escapes it, ``$$x``, and a node's value refused at import was shown in that
escape: ``<wait duration="$x"/>`` said *not a quantity: '$$x'*, and ``$$x`` said
``'$$$x'``, texts nobody wrote.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.cli import main


@pytest.mark.parametrize(
    ("node", "said"),
    [
        (
            '<wait duration="$x"/>',
            "wait: duration: not a quantity: '$x' (expected e.g. '90 deg', '80 mm/s')",
        ),
        (
            '<wait duration="$$x"/>',
            "wait: duration: not a quantity: '$$x' (expected e.g. '90 deg', '80 mm/s')",
        ),
        ('<is_clamped half="$x"/>', "is_clamped: half: '$x' is not one of front, rear"),
        (
            '<retry attempts="$x"><success/></retry>',
            "retry: attempts: must be a whole number, not '$x'",
        ),
    ],
    ids=["quantity", "two-dollars", "choice", "count"],
)
def test_a_refused_value_is_shown_as_the_xml_wrote_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], node: str, said: str
) -> None:
    xml = tmp_path / "t.xml"
    xml.write_text(
        '<root BTCPP_format="4" main_tree_to_execute="M">\n'
        f'<BehaviorTree ID="M">{node}</BehaviorTree>\n</root>\n',
        encoding="utf-8",
    )
    assert main(["validate", str(xml)]) == 2
    assert capsys.readouterr().err.replace(str(xml), "t.xml") == f"t.xml:2:22: {said}\n"
