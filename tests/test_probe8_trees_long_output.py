"""Probe 8 (hostile trees), with the atomic.py patch: render writes a picture whose
name has nearly the 255 bytes a name may have (its temporary .NAME.XXXXXXXX.part
was too long: 'File name too long')."""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.cli import main


def test_render_to_a_long_legal_name(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    tree = tmp_path / "tree.yaml"
    tree.write_text("root: {type: wait, duration: 1 s}\n", encoding="utf-8")
    out = tmp_path / ("d" * 251 + ".dot")
    assert main(["render", str(tree), "-o", str(out)]) == 0, capsys.readouterr().err
    assert out.read_text(encoding="utf-8").startswith("digraph")
