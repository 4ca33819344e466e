"""A ``<SubTree>`` model's port names in BT.CPP XML (docs/interop.md, Subtrees and
parameters): a port named ``name``, ``ID``, ``_skipIf`` (BT.CPP's reserved attributes,
which BT.CPP 4.9 refuses in a ``<SubTree>`` model) or ``_x`` (no call can give it in
BT.CPP) was imported, and the export then refused the tree it made.
"""

from __future__ import annotations

from pathlib import Path

import pytest

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


@pytest.mark.parametrize("port", ["name", "ID", "_skipIf", "_while", "_x"])
def test_a_port_name_bt_cpp_takes_for_no_port_is_refused_at_import(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], port: str
) -> None:
    xml = _write(tmp_path, port=port, attrs=' default="hi"')
    out = tmp_path / "t.yaml"
    assert main(["import", "btcpp", str(xml), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    assert (
        f"{xml}:4:33: port name {port!r}: BehaviorTree.CPP takes no port of this name"
        " (a port name starts with a letter A-Z or a-z and is not 'name' or 'ID';"
    ) in err, err
    assert not out.exists()


def test_a_port_name_import_takes_is_one_export_takes(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    xml = _write(tmp_path, port="label", attrs=' default="hi"')
    out, back = tmp_path / "t.yaml", tmp_path / "back.xml"
    assert main(["import", "btcpp", str(xml), "-o", str(out)]) == 0, capsys.readouterr().err
    assert main(["export", "btcpp", str(out), "-o", str(back)]) == 0, capsys.readouterr().err
