"""A count of BT.CPP's own nodes written with ``json:`` (docs/interop.md, Values).

``<Parallel success_count="json:true">`` (also ``json:1.0``) was imported as a
parallel that succeeds on one child, and ``<RetryUntilSuccessful num_attempts="json:3">``
as three attempts; BT.CPP refuses each such file (*The port with name "success_count"
and value "json:true" can not be converted to int*): its counts are int ports, read by
``convertFromString<int>`` (``std::from_chars``), which takes no ``json:``.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.cli import main

_CASES = [
    ("Parallel", "success_count", "json:true"),
    ("Parallel", "failure_count", "json:1.0"),
    ("RetryUntilSuccessful", "num_attempts", "json:3"),
    ("Repeat", "num_cycles", "json:3"),
]


def _xml(tag: str, port: str, value: str) -> str:
    children = "<AlwaysSuccess/><AlwaysSuccess/>" if tag == "Parallel" else "<AlwaysSuccess/>"
    return (
        '<root BTCPP_format="4" main_tree_to_execute="T">\n'
        f'<BehaviorTree ID="T"><{tag} {port}="{value}">{children}</{tag}></BehaviorTree>\n'
        "</root>\n"
    )


@pytest.mark.parametrize(("tag", "port", "value"), _CASES)
def test_a_count_written_as_json_is_refused_as_bt_cpp_refuses_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], tag: str, port: str, value: str
) -> None:
    xml = tmp_path / "t.xml"
    xml.write_text(_xml(tag, port, value), encoding="utf-8")
    assert main(["validate", str(xml)]) == 2
    assert capsys.readouterr().err.replace(str(xml), "t.xml") == (
        f"t.xml:2:22: {port}={value!r}: BT.CPP reads <{tag}>'s {port} as an int, digits"
        f' only, not json: ({port}="1")\n'
    )


@pytest.mark.parametrize(("tag", "port", "value"), _CASES)
def test_bt_cpp_itself_refuses_them(tag: str, port: str, value: str) -> None:
    bt = pytest.importorskip("behaviortreepy")
    factory = bt.BehaviorTreeFactory()
    factory.register_behavior_tree_from_text(_xml(tag, port, value))
    with pytest.raises(Exception, match="can not be converted to int"):
        factory.create_tree("T")


@pytest.mark.parametrize(("tag", "port"), [(t, p) for t, p, _ in _CASES])
def test_the_same_counts_in_digits_load(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], tag: str, port: str
) -> None:
    xml = tmp_path / "t.xml"
    xml.write_text(_xml(tag, port, "1"), encoding="utf-8")
    assert (main(["validate", str(xml)]), capsys.readouterr().err) == (0, "")
