"""A ``<SubTree>`` model's ``choices`` in BT.CPP XML (docs/interop.md, Subtrees and
parameters): ``choices="a;b"``, as the file's own node models write them, was refused
as *must be a list*, naming no form that works.
"""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from pirate_bt.cli import main

_FILE = (
    '<root BTCPP_format="4" main_tree_to_execute="m">\n'
    '<BehaviorTree ID="m"><SubTree ID="s" {call}/></BehaviorTree>\n'
    '<BehaviorTree ID="s"><log message="{{{port}}}"/></BehaviorTree>\n'
    '<TreeNodesModel><SubTree ID="s"><input_port name="{port}" type="string"{attrs}/>'
    "</SubTree></TreeNodesModel></root>\n"
)


def _write(tmp_path: Path, port: str = "side", call: str = "", attrs: str = "") -> Path:
    xml = tmp_path / "t.xml"
    xml.write_text(_FILE.format(port=port, call=call, attrs=attrs), encoding="utf-8")
    return xml


def test_choices_written_as_node_models_write_them_are_taken(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    xml = _write(tmp_path, call='side="left"', attrs=' choices="left;right"')
    out = tmp_path / "t.yaml"
    assert main(["import", "btcpp", str(xml), "-o", str(out)]) == 0, capsys.readouterr().err
    data = yaml.safe_load(out.read_text(encoding="utf-8"))
    assert data["subtrees"]["s"]["params"]["side"]["choices"] == ["left", "right"]
    # and they are the port's choices: a call outside them is refused
    xml = _write(tmp_path, call='side="up"', attrs=' choices="left;right"')
    assert main(["validate", str(xml)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "expected one of left, right, got 'up'" in err, err


@pytest.mark.parametrize("choices", ['json:"left"', "", "json:[]"])
def test_choices_that_are_no_list_name_the_forms_that_work(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], choices: str
) -> None:
    xml = _write(tmp_path, call='side="left"', attrs=f" choices='{choices}'")
    assert main(["validate", str(xml)]) == 2
    err = capsys.readouterr().err
    assert err == (
        f"{xml}:4:33: port 'side': choices {choices!r}: a list of one or more,"
        ' written a;b;c or json:["a", "b"]\n'
    ), err
