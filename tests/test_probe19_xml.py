"""Probe 19: BehaviorTree.CPP XML both ways, at the seams with BT.CPP's own parser
(its sources in the behaviortreepy distribution) and with the tree loader (see
docs/interop.md).

Findings, each with its test below:

- a subtree parameter whose default is the empty text was exported as the model's
  ``default=""``, which BT.CPP takes for no default: every call of that subtree that
  left the parameter out was refused by BT.CPP ("is defining a mandatory port ...
  but you are not remapping it");
"""

from __future__ import annotations

import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import pytest
import yaml

from pirate_bt.cli import main

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def checker() -> Path:
    sys.path.insert(0, str(ROOT / "tests" / "btcpp_checker"))
    try:
        import build as checker_build  # type: ignore[import-not-found]
    finally:
        sys.path.pop(0)
    try:
        return Path(checker_build.build_checker())
    except checker_build.Unavailable as exc:
        pytest.skip(f"BT.CPP port checker unavailable: {exc}")


_EMPTY_DEFAULT = """\
name: t
subtrees:
  say:
    params:
      msg: {type: string, default: ""}
    root: {type: log, message: $msg}
root:
  type: sequence
  children:
    - {type: subtree, ref: say}
"""


def test_an_empty_default_is_given_at_each_call_and_read_back_as_the_default(
    tmp_path: Path, capsys: Any
) -> None:
    # BT.CPP reads a <SubTree> model's default="" as no default, and refused the call
    # that leaves the parameter out; the empty text is now written at the call
    source = tmp_path / "t.yaml"
    source.write_text(_EMPTY_DEFAULT, encoding="utf-8")
    xml, back = tmp_path / "t.xml", tmp_path / "back.yaml"
    assert main(["export", "btcpp", str(source), "-o", str(xml)]) == 0
    call = ET.parse(xml).getroot().find("BehaviorTree[@ID='t']//SubTree[@ID='say']")
    assert call is not None
    assert call.attrib.get("msg") == ""
    assert main(["import", "btcpp", str(xml), "-o", str(back)]) == 0
    assert yaml.safe_load(back.read_text(encoding="utf-8")) == yaml.safe_load(_EMPTY_DEFAULT)
    capsys.readouterr()


def test_bt_cpp_builds_a_call_that_leaves_an_empty_default_out(
    checker: Path, tmp_path: Path, capsys: Any
) -> None:
    source = tmp_path / "t.yaml"
    source.write_text(_EMPTY_DEFAULT, encoding="utf-8")
    xml = tmp_path / "t.xml"
    assert main(["export", "btcpp", str(source), "-o", str(xml)]) == 0
    result = subprocess.run(
        [str(checker), str(xml)], capture_output=True, text=True, timeout=60, check=False
    )
    assert result.returncode == 0, result.stdout + result.stderr
    capsys.readouterr()
