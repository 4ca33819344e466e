"""A BehaviorTree.CPP v4 XML tree (Groot2's file) runs and validates as it is.

Before 2026-11-29 ``pirate-bt run tree.xml`` read the XML as YAML (*tree.xml:51:68: YAML
syntax error*) and ``pirate-bt validate tree.xml`` could not tell its kind: only
``pirate-bt import btcpp`` took it. Now run, validate and ``simulate_tree`` convert it
as the import does (each problem at its XML element), in a temporary folder.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import pytest

import pirate_bt
from pirate_bt.cli import main
from pirate_bt.errors import LocatedError

REPO = Path(__file__).resolve().parent.parent
UNKNOWN = (
    '<root BTCPP_format="4" main_tree_to_execute="T">\n'
    '  <BehaviorTree ID="T">\n'
    "    <Sequence>\n"
    "      <Fly/>\n"
    "    </Sequence>\n"
    "  </BehaviorTree>\n"
    "</root>\n"
)


@pytest.fixture
def straight_xml(tmp_path: Path) -> Path:
    out = tmp_path / "straight.xml"
    assert main(["export", "btcpp", str(REPO / "trees" / "straight.yaml"), "-o", str(out)]) == 0
    return out


@pytest.fixture
def private_tmp(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """Temporary folders made here, to see that none is left behind."""
    folder = tmp_path / "tmp"
    folder.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(folder))
    return folder


def test_an_xml_tree_runs_as_its_yaml_does(straight_xml: Path, private_tmp: Path) -> None:
    params = {"distance": "0.2 m"}
    from_xml = pirate_bt.simulate_tree(straight_xml, params=params)
    from_yaml = pirate_bt.simulate_tree(REPO / "trees" / "straight.yaml", params=params)
    assert from_xml.succeeded and from_yaml.succeeded
    assert from_xml.ticks == from_yaml.ticks and from_xml.why == from_yaml.why
    assert list(private_tmp.iterdir()) == []  # the converted file went with its folder


def test_the_command_line_runs_and_validates_an_xml_tree(
    straight_xml: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    run = ["run", str(straight_xml), "--sim", "straight", "--param", "distance=0.2m", "--quiet"]
    assert main(run) == 0
    assert "straight: SUCCESS" in capsys.readouterr().out
    assert main(["validate", str(straight_xml)]) == 0
    assert capsys.readouterr().out.strip() == f"{straight_xml}: ok"
    # a parameter's error is the command line's, as for a YAML tree
    assert main([*run[:-2], "distance=banana"]) == 2
    err = capsys.readouterr().err
    assert "--param distance=banana: parameter 'distance': not a quantity: 'banana'" in err


def test_a_bad_xml_tree_is_refused_at_its_element_before_anything_runs(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bad = tmp_path / "fly.xml"
    bad.write_text(UNKNOWN)
    assert main(["validate", str(bad)]) == 2
    assert capsys.readouterr().err.strip() == f"{bad}:4:7: unknown node type 'Fly'"
    assert main(["run", str(bad), "--sim", "straight", "--quiet"]) == 2
    assert f"{bad}:4:7: unknown node type 'Fly'" in capsys.readouterr().err
    hostile = tmp_path / "lol.xml"
    hostile.write_text('<!DOCTYPE r [<!ENTITY a "aaaa">]>\n' + UNKNOWN)
    with pytest.raises(LocatedError, match="a DOCTYPE is not allowed"):
        pirate_bt.simulate_tree(hostile)
