"""Probe 8 (hostile trees): node names are drawn as written in a trace plot.

matplotlib reads text between two ``$`` as a formula: a step named ``a $\\frac{$ b``
made ``pirate-bt trace plot`` exit 1 with a three-line *internal error: ValueError*
from mathtext, and one named ``$x^2$`` was drawn as x squared.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.cli import main

pytest.importorskip("matplotlib")

TREE = """\
root:
  type: sequence
  name: "root $5"
  children:
    - {type: wait, name: "a $\\\\frac{$ b", duration: 1 s}
    - {type: wait, name: "$x^2$", duration: 1 s}
"""


def test_dollar_signs_in_names_are_no_formula(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    import matplotlib

    tree = tmp_path / "tree.yaml"
    tree.write_text(TREE, encoding="utf-8")
    trace = tmp_path / "run.jsonl"
    assert main(["run", str(tree), "--quiet", "--trace", str(trace)]) == 0
    monkeypatch.setitem(matplotlib.rcParams, "svg.fonttype", "none")  # text as text
    out = tmp_path / "plot.svg"
    assert main(["trace", "plot", str(trace), "-o", str(out)]) == 0, capsys.readouterr().err
    svg = out.read_text(encoding="utf-8")
    assert "a $\\frac{$ b" in svg
    assert "$x^2$" in svg
    assert "root $5: success" in svg
