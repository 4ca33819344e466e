"""Probe 18: BehaviorTree.CPP XML both ways, as a hostile peer would send it and as a
user would export it (see docs/interop.md)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from pirate_bt.cli import main

_BODY = (
    '<root BTCPP_format="4"><BehaviorTree ID="M">'
    '<AlwaysSuccess name="caf\u00e9 \u65e5"/></BehaviorTree></root>\n'
)


def _import(tmp_path: Path, data: bytes, capsys: Any) -> tuple[int, str, Path]:
    source = tmp_path / "in.xml"
    source.write_bytes(data)
    out = tmp_path / "out" / "t.yaml"
    code = main(["import", "btcpp", str(source), "-o", str(out)])
    return code, capsys.readouterr().err, out


@pytest.mark.parametrize(
    ("encoding", "body"),
    [
        ("idna", _BODY),
        ("punycode", _BODY.replace("caf\u00e9 \u65e5", "cafe")),
        ("undefined", _BODY),
    ],
    ids=["idna", "punycode", "undefined"],
)
def test_a_declared_codec_that_fails_without_a_place_is_refused_in_one_line(
    encoding: str, body: str, tmp_path: Path, capsys: Any
) -> None:
    # These codecs raise a bare UnicodeError (idna also has no "replace" handler):
    # the import said "internal error" and exited 1, as if a run had failed.
    data = f'<?xml version="1.0" encoding="{encoding}"?>\n{body}'.encode()
    code, err, out = _import(tmp_path, data, capsys)
    assert code == 2
    assert err.count("\n") == 1
    assert f"in.xml:1:1: not {encoding} text, as its XML declaration says" in err
    assert "internal error" not in err
    assert not out.parent.exists()
