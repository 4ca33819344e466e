"""Hostile YAML tree files said as what they are, one located line each.

A UTF-32 file (a byte-order mark ``FF FE 00 00`` starts as UTF-16's) was said to be
*UTF-16 text*, and one in big-endian order (``00 00 FE FF``) a *binary file*. An anchor
defined twice (``&a`` on two values, which PyYAML refuses) was *YAML syntax error:
second occurrence*, PyYAML's second half of a two-part message.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.cli import main

_TREE = "name: t\nroot: {type: wait, duration: 1 s}\n"


def _validate(tmp_path: Path, capsys: pytest.CaptureFixture[str], data: bytes) -> tuple[int, str]:
    tree = tmp_path / "t.yaml"
    tree.write_bytes(data)
    code = main(["validate", str(tree)])
    return code, capsys.readouterr().err.replace(str(tree), "t.yaml")


@pytest.mark.parametrize("codec", ["utf-32", "utf-32-le", "utf-32-be"])
def test_a_utf32_file_is_said_to_be_utf32(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], codec: str
) -> None:
    data = ("" if codec == "utf-32" else "\ufeff") + _TREE
    assert _validate(tmp_path, capsys, data.encode(codec)) == (
        2,
        "t.yaml:1:1: UTF-32 text; save the file as UTF-8\n",
    )


@pytest.mark.parametrize("codec", ["utf-16", "utf-16-be"])
def test_a_utf16_file_is_still_said_to_be_utf16(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], codec: str
) -> None:
    data = ("" if codec == "utf-16" else "\ufeff") + _TREE
    assert _validate(tmp_path, capsys, data.encode(codec)) == (
        2,
        "t.yaml:1:1: UTF-16 text; save the file as UTF-8\n",
    )


def test_an_anchor_defined_twice_says_so_and_where_the_first_is(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    data = b"name: &a t\nroot:\n  type: sequence\n  children: [&a success]\n"
    assert _validate(tmp_path, capsys, data) == (
        2,
        "t.yaml:4:14: YAML anchor defined twice (first at line 1); name each its own\n",
    )
