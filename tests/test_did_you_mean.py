"""A misspelt key or parameter is one problem with a hint, not two.

``torq:`` for ``torque:`` was said twice: "unknown key 'torq'" and "missing required
key 'torque'"; ``--param distanse=1m`` as "unknown parameter 'distanse'" and "parameter
'distance' has no default and was not given".
"""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.cli import main


def _validate(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], name: str, text: str
) -> list[str]:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    assert main(["validate", str(path)]) == 2
    return [line.replace(str(path), "FILE") for line in capsys.readouterr().err.splitlines()]


def test_a_misspelt_network_key_is_one_line_with_the_key_meant(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    text = (
        "schema_version: 1\nname: n\ndiamter: 63 mm\nsegments:\n  - {type: straight, lenght: 2 m}\n"
    )
    assert _validate(tmp_path, capsys, "n.yaml", text) == [
        "FILE:3:1: unknown key 'diamter' (did you mean 'diameter'?)",
        "FILE:5:22: unknown key 'lenght' (did you mean 'length'?)",
    ]


def test_a_key_close_to_no_missing_one_keeps_both_problems(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    text = (
        "schema_version: 1\nname: n\nwidth: 63 mm\nsegments:\n  - {type: straight, length: 2 m}\n"
    )
    lines = _validate(tmp_path, capsys, "n.yaml", text)
    assert len(lines) == 2 and not any("did you mean" in line for line in lines), lines
    assert "unknown key 'width'" in " ".join(lines)
    assert "missing required key 'diameter'" in " ".join(lines)


def test_a_misspelt_node_key_in_a_tree_names_the_key_meant(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    text = "name: t\nroot:\n  type: sequence\n  children:\n    - {type: wait, duratoin: 1 s}\n"
    lines = _validate(tmp_path, capsys, "t.yaml", text)
    assert lines == ["FILE:5:20: wait: unknown key 'duratoin' (did you mean 'duration'?)"]
