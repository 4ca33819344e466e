"""Session 22 (R2): the magnitude of a tree's quantity parameters (docs/trees.md).

``load_tree("straight", params={"distance": 2**62})`` was taken: 4.6e18 m, a finite
double, went on to the drive. A quantity parameter is now refused beyond
``units.MAGNITUDE_LIMITS`` (a length at most 1,000 km either way), in one line naming
the parameter, wherever it is given: from Python, on the command line, in a file.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt import load_tree
from pirate_bt.cli import main
from pirate_bt.errors import ValidationFailed

SAID = "is out of range: a length is at most 1e+06 m (either sign)"


@pytest.mark.parametrize("distance", [2**62, -(2**62), 1e300, "1e300 m", "-2000 km"])
def test_an_absurd_distance_given_from_python_is_refused_naming_the_parameter(
    distance: object,
) -> None:
    with pytest.raises(ValidationFailed) as caught:
        load_tree("straight", params={"distance": distance})
    said = str(caught.value)
    assert "\n" not in said
    assert "parameter 'distance': " in said and SAID in said


def test_an_absurd_distance_on_the_command_line_is_refused_in_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "t.dot"
    assert main(["render", "straight", "--param", "distance=1e300m", "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "distance" in err and SAID in err
    assert not out.exists()


def test_an_absurd_value_at_a_subtree_call_is_refused_at_its_place(tmp_path: Path) -> None:
    path = tmp_path / "t.yaml"
    path.write_text(
        "name: t\n"
        "subtrees:\n"
        "  go:\n"
        "    params: {d: {type: length}}\n"
        "    root: {type: wait, duration: 1 s}\n"
        "root: {type: subtree, ref: go, params: {d: 2e6 m}}\n",
        encoding="utf-8",
    )
    with pytest.raises(ValidationFailed) as caught:
        load_tree(path)
    assert f"{path}:6:" in str(caught.value) and "'2e6 m' " + SAID in str(caught.value)


def test_a_long_but_possible_distance_is_taken() -> None:
    assert load_tree("straight", params={"distance": "1000 km"}).params["distance"] == "1000000.0 m"


def test_an_absurd_quantity_written_as_a_node_s_key_is_refused_at_its_place(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "k.yaml"
    path.write_text(
        "name: t\n"
        "root:\n"
        "  type: sequence\n"
        "  children:\n"
        "    - {type: wait, duration: 1e300 s}\n"
        "    - {type: drive, velocity: 80 mm/s, distance: 2000 km}\n"
        "    - {type: wait, duration: 10 h}\n",
        encoding="utf-8",
    )
    assert main(["validate", str(path)]) == 2
    assert capsys.readouterr().err.splitlines() == [
        f"{path}:5:20: wait: '1e300 s' is out of range: a time is at most 1e+09 s (either sign)",
        f"{path}:6:40: drive: '2000 km' {SAID}",
    ]


def test_an_absurd_quantity_in_bt_cpp_xml_is_refused_at_its_element(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    xml = tmp_path / "k.xml"
    xml.write_text(
        '<root BTCPP_format="4"><BehaviorTree ID="T">'
        '<wait duration="1e300 s"/></BehaviorTree></root>\n',
        encoding="utf-8",
    )
    assert main(["import", "btcpp", str(xml), "-o", str(tmp_path / "k.yaml")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{xml}:1:" in err
    assert "'1e300 s' is out of range: a time is at most 1e+09 s" in err
    assert not (tmp_path / "k.yaml").exists()
