"""Hostile BT.CPP XML bytes said as what they are, one located line each.

A file saved as Latin-1 (or Windows-1252) without an XML declaration naming it, and a
NUL byte, were *not well-formed XML: not well-formed (invalid token)*, expat's word for
any token it cannot read, which names neither the byte nor the way out. BT.CPP's parser
(tinyxml2) reads the bytes as UTF-8 unchecked and runs the file with the text mangled.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.cli import main

_FILE = (
    '<root BTCPP_format="4" main_tree_to_execute="M">\n'
    '<BehaviorTree ID="M"><log message="{message}"/></BehaviorTree>\n'
    "</root>\n"
)


def _validate(tmp_path: Path, capsys: pytest.CaptureFixture[str], data: bytes) -> tuple[int, str]:
    xml = tmp_path / "t.xml"
    xml.write_bytes(data)
    code = main(["validate", str(xml)])
    return code, capsys.readouterr().err.replace(str(xml), "t.xml")


@pytest.mark.parametrize("bom", [b"", b"\xef\xbb\xbf"], ids=["plain", "utf8-bom"])
def test_a_byte_that_is_no_utf8_is_named_with_the_way_out(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], bom: bytes
) -> None:
    data = bom + _FILE.format(message="caf\u00e9").encode("latin-1")
    assert _validate(tmp_path, capsys, data) == (
        2,
        "t.xml:2:39: not well-formed XML: not UTF-8 text (byte 0xe9): save the file as"
        ' UTF-8, or name its encoding (<?xml version="1.0" encoding="ISO-8859-1"?>)\n',
    )


def test_a_nul_byte_is_named(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    data = _FILE.format(message="a\x00b").encode()
    assert _validate(tmp_path, capsys, data) == (
        2,
        "t.xml:2:37: not well-formed XML: a NUL byte (U+0000), which XML does not allow\n",
    )


def test_the_same_bytes_in_their_declared_encoding_load(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    declared = '<?xml version="1.0" encoding="ISO-8859-1"?>\n' + _FILE.format(message="caf\u00e9")
    assert _validate(tmp_path, capsys, declared.encode("latin-1")) == (0, "")


def test_any_other_invalid_token_keeps_expat_s_words(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    data = _FILE.replace("<log", "<!-- a -- b --><log").format(message="x").encode()
    assert _validate(tmp_path, capsys, data) == (
        2,
        "t.xml:2:31: not well-formed XML: not well-formed (invalid token)\n",
    )
