"""BT.CPP XML port values read as BehaviorTree.CPP reads them (docs/interop.md, Values).

BT.CPP converts an integer, number or boolean port's text with its
``convertFromString`` (``std::from_chars``, base 10, for numbers): an optional
``-`` and the digits, no ``+``, no space before, and only ``true``/``True``/``TRUE``/
``1`` or their ``false`` forms for a boolean. ``<RetryUntilSuccessful
num_attempts="+3">`` and ``" 3"`` were taken as 3 by the import, where BT.CPP refuses
the file ("can not be converted to int"). A text BT.CPP reads only the start of
(``3abc``, ``3.5`` as 3) is refused too, saying what BT.CPP would run.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from pirate_bt.cli import main
from pirate_bt.interop.btcpp import decode_value

ROOT = Path(__file__).resolve().parents[1]

_RETRY = (
    '<root BTCPP_format="4"><BehaviorTree ID="m">\n'
    '  <RetryUntilSuccessful num_attempts="{value}"><AlwaysSuccess/></RetryUntilSuccessful>\n'
    "</BehaviorTree></root>\n"
)


@pytest.mark.parametrize(
    ("value", "why"),
    [
        ("+3", "BT.CPP reads no '+'"),
        (" 3", "BT.CPP reads no space before it"),
        ("3abc", "BT.CPP would read it as '3', dropping the rest"),
        ("3.5", "BT.CPP would read it as '3', dropping the rest"),
        ("0x3", "BT.CPP would read it as '0', dropping the rest"),
        ("", "BT.CPP reads an optional '-' and the digits 0-9"),
    ],
)
def test_an_integer_port_bt_cpp_does_not_read_whole_is_refused_in_one_located_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], value: str, why: str
) -> None:
    xml = tmp_path / "t.xml"
    xml.write_text(_RETRY.format(value=value), encoding="utf-8")
    assert main(["validate", str(xml)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    assert err.startswith(f"{xml}:2:3: num_attempts: expected an integer, got {value!r}: "), err
    assert why in err, err


@pytest.mark.parametrize(("value", "times"), [("3", 3), ("003", 3)])
def test_an_integer_port_bt_cpp_reads_whole_is_taken(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], value: str, times: int
) -> None:
    xml, out = tmp_path / "t.xml", tmp_path / "t.yaml"
    xml.write_text(_RETRY.format(value=value), encoding="utf-8")
    assert main(["import", "btcpp", str(xml), "-o", str(out)]) == 0, capsys.readouterr().err
    assert yaml.safe_load(out.read_text(encoding="utf-8"))["root"]["attempts"] == times


_SUBTREE = (
    '<root BTCPP_format="4" main_tree_to_execute="m">\n'
    '<BehaviorTree ID="m" _blackboard=\'json:{{"k": {{"type": "number"}}}}\'>'
    '<SubTree ID="s" x="{value}"/></BehaviorTree>\n'
    '<BehaviorTree ID="s"><set_blackboard key="k" value="{{x}}"/></BehaviorTree>\n'
    '<TreeNodesModel><SubTree ID="s"><input_port name="x" type="number"/></SubTree>'
    "</TreeNodesModel></root>\n"
)


@pytest.mark.parametrize("value", ["+1.5", " 1.5", "1.5 m"])
def test_a_number_port_bt_cpp_does_not_read_whole_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], value: str
) -> None:
    xml = tmp_path / "t.xml"
    xml.write_text(_SUBTREE.format(value=value), encoding="utf-8")
    assert main(["validate", str(xml)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    assert err.startswith(f"{xml}:2:67: x: expected a number, got {value!r}: BT.CPP 4.9 "), err


@pytest.mark.parametrize(("value", "number"), [("-1.5", -1.5), (".5", 0.5), ("1e3", 1000.0)])
def test_a_number_port_bt_cpp_reads_whole_is_taken(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], value: str, number: float
) -> None:
    xml, out = tmp_path / "t.xml", tmp_path / "t.yaml"
    xml.write_text(_SUBTREE.format(value=value), encoding="utf-8")
    assert main(["import", "btcpp", str(xml), "-o", str(out)]) == 0, capsys.readouterr().err
    assert yaml.safe_load(out.read_text(encoding="utf-8"))["root"]["params"] == {"x": number}


_DRIVE = (
    '<root BTCPP_format="4"><BehaviorTree ID="m">\n'
    '  <drive velocity="20 mm/s" distance="0.1 m" reverse="{value}"/>\n'
    "</BehaviorTree></root>\n"
)


@pytest.mark.parametrize("value", [" true", "tRuE", "yes", "false "])
def test_a_boolean_port_bt_cpp_refuses_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], value: str
) -> None:
    xml = tmp_path / "t.xml"
    xml.write_text(_DRIVE.format(value=value), encoding="utf-8")
    assert main(["validate", str(xml)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    assert f"{xml}:2:3: drive: reverse: expected true or false, got {value!r}" in err, err
    assert "BT.CPP reads true, True, TRUE or 1" in err, err


@pytest.mark.parametrize("value", ["True", "TRUE", "1", "False", "0"])
def test_a_boolean_port_as_bt_cpp_spells_it_is_taken(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], value: str
) -> None:
    xml = tmp_path / "t.xml"
    xml.write_text(_DRIVE.format(value=value), encoding="utf-8")
    assert main(["validate", str(xml)]) == 0, capsys.readouterr().err


def test_run_once_s_then_skip_is_read_as_bt_cpp_reads_a_boolean(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    xml = tmp_path / "t.xml"
    xml.write_text(
        '<root BTCPP_format="4"><BehaviorTree ID="m">\n'
        '  <RunOnce then_skip="fAlSe"><AlwaysSuccess/></RunOnce>\n'
        "</BehaviorTree></root>\n",
        encoding="utf-8",
    )
    assert main(["validate", str(xml)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"{xml}:2:3: then_skip: expected true or false, got 'fAlSe'"), err


# -- against BT.CPP itself ---------------------------------------------------------


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


_TEXTS = {
    "integer": ["3", "-3", "003", "+3", " 3", "3 ", "3abc", "3.5", "0x3", "", "1_0"],
    "number": ["1.5", "-1.5", ".5", "5.", "1e3", "+1.5", " 1.5", "1.5 m", "0x1p3", "1e"],
    "boolean": ["true", "True", "TRUE", "1", "false", "0", " true", "tRuE", "yes", "true "],
}


def _btcpp_takes(checker: Path, tmp_path: Path, port_type: str, text: str) -> bool:
    xml = tmp_path / "probe.xml"
    escaped = text.replace("&", "&amp;").replace('"', "&quot;")
    xml.write_text(
        '<root BTCPP_format="4" main_tree_to_execute="m">'
        f'<BehaviorTree ID="m"><probe p="{escaped}"/></BehaviorTree>'
        f'<TreeNodesModel><Action ID="probe"><input_port name="p" type="{port_type}"/>'
        "</Action></TreeNodesModel></root>\n",
        encoding="utf-8",
    )
    result = subprocess.run(
        [str(checker), str(xml)], capture_output=True, text=True, timeout=60, check=False
    )
    assert result.stdout.startswith(("ok", "error: The port")), result.stdout + result.stderr
    return result.returncode == 0


@pytest.mark.parametrize("port_type", sorted(_TEXTS))
def test_a_port_value_is_taken_only_when_bt_cpp_reads_all_of_it(
    checker: Path, tmp_path: Path, port_type: str
) -> None:
    for text in _TEXTS[port_type]:
        btcpp = _btcpp_takes(checker, tmp_path, port_type, text)
        try:
            decode_value(text, port_type, "p")
        except ValueError as exc:
            # refused: BT.CPP refuses it too, or reads only its start (and we say so); a
            # number: BT.CPP before 4.9 (std::stod) takes more than 4.9's from_chars
            said = str(exc)
            assert not btcpp or "would read it as" in said or port_type == "number", said
        else:
            assert btcpp, f"{text!r} is taken as {port_type}, BT.CPP refuses it"


_PARALLEL = (
    '<root BTCPP_format="4"><BehaviorTree ID="m">\n'
    '  <Parallel success_count="{value}" failure_count="1"><AlwaysSuccess/><AlwaysSuccess/>'
    "</Parallel>\n</BehaviorTree></root>\n"
)


def test_parallel_s_counts_are_read_as_bt_cpp_reads_an_int(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # '01' is BT.CPP's 1 (policy one); '+1' BT.CPP refuses, for its '+', not for the count
    xml, out = tmp_path / "t.xml", tmp_path / "t.yaml"
    xml.write_text(_PARALLEL.format(value="01"), encoding="utf-8")
    assert main(["import", "btcpp", str(xml), "-o", str(out)]) == 0, capsys.readouterr().err
    assert yaml.safe_load(out.read_text(encoding="utf-8"))["root"]["policy"] == "one"
    xml.write_text(_PARALLEL.format(value="+1"), encoding="utf-8")
    assert main(["validate", str(xml)]) == 2
    err = capsys.readouterr().err
    assert err == (
        f"{xml}:2:3: success_count: expected an integer, got '+1': BT.CPP reads no '+':"
        " write it without\n"
    ), err


_NUMBER_TREE = """\
name: t
params:
  x: {type: number, default: 1.0}
blackboard:
  k: {type: number}
root: {type: set_blackboard, key: k, value: $x}
"""


@pytest.mark.parametrize("given", ["+1.5", "+.15e1"])
def test_a_number_param_given_as_bt_cpp_does_not_read_it_is_exported_as_the_run_read_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], given: str
) -> None:
    source, xml, back = tmp_path / "t.yaml", tmp_path / "t.xml", tmp_path / "back.yaml"
    source.write_text(_NUMBER_TREE, encoding="utf-8")
    assert main(["export", "btcpp", str(source), "--param", f"x={given}", "-o", str(xml)]) == 0
    assert main(["import", "btcpp", str(xml), "-o", str(back)]) == 0, capsys.readouterr().err
    assert yaml.safe_load(back.read_text(encoding="utf-8"))["params"]["x"]["default"] == 1.5
