"""A ``<SubTree>`` call's ``_autoremap`` and the attributes BT.CPP takes for no port
(docs/interop.md, Limits): BT.CPP reads ``_autoremap`` as a bool (``convertFromString
<bool>``: true, True, TRUE, 1, false, False, FALSE, 0, anything else refuses the file),
and ignores an attribute whose name starts with no ASCII letter (``IsAllowedPortName``).
"""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.cli import main

_FILE = (
    '<root BTCPP_format="4" main_tree_to_execute="M">\n'
    '<BehaviorTree ID="M"><SubTree ID="S" {call}/></BehaviorTree>\n'
    '<BehaviorTree ID="S"><AlwaysSuccess {attrs}/></BehaviorTree>\n'
    "</root>\n"
)


def _import(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], call: str, attrs: str = ""
) -> tuple[int, str, Path]:
    xml = tmp_path / "t.xml"
    xml.write_text(_FILE.format(call=call, attrs=attrs), encoding="utf-8")
    code = main(["import", "btcpp", str(xml), "-o", str(tmp_path / "t.yaml")])
    return code, capsys.readouterr().err, xml


@pytest.mark.parametrize("value", ["yes", "", "{=}", "{x}", "json:true", "2", " true"])
def test_an_autoremap_that_is_no_bool_is_refused_as_bt_cpp_refuses_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], value: str
) -> None:
    # it was refused as "_autoremap is not supported", as if the call asked for it
    code, err, xml = _import(tmp_path, capsys, f'_autoremap="{value}"')
    assert code == 2
    assert err == (
        f"pirate-bt: {xml}:2:22: _autoremap={value!r}: expected true or false"
        " (BT.CPP reads true, True, TRUE or 1, false, False, FALSE or 0)\n"
    )


@pytest.mark.parametrize("value", ["true", "True", "TRUE", "1"])
def test_an_autoremap_that_is_true_is_still_refused_as_unsupported(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], value: str
) -> None:
    code, err, xml = _import(tmp_path, capsys, f'_autoremap="{value}"')
    assert code == 2
    assert err == (
        f"pirate-bt: {xml}:2:22: _autoremap is not supported: remap each port explicitly\n"
    )


def test_attributes_bt_cpp_takes_for_no_port_are_ignored_as_bt_cpp_ignores_them(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # 'éx' (no ASCII letter first) was taken for a port: "port 'éx' is not a parameter
    # of 'S'", "<AlwaysSuccess> has no port 'éx'"; BT.CPP loads the file
    code, err, _ = _import(tmp_path, capsys, 'éx="{x}"', attrs='ö="1"')
    assert (code, err) == (0, "")
    assert "éx" not in (tmp_path / "t.yaml").read_text(encoding="utf-8")
