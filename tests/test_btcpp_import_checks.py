"""``pirate-bt import btcpp`` applies every check the loader applies for the robot.

An XML file that converts but would not load for the robot (a clamp torque above
the joints' limit, a quantity without its unit, a node type that does not exist)
is refused with each problem at ``file.xml:line:column``, exit code 2, and
nothing written: not the tree file, not a temporary one.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.cli import main
from pirate_bt.errors import ValidationFailed
from pirate_bt.interop.btcpp import import_xml

ROOT = Path(__file__).resolve().parent.parent

XML = """<?xml version="1.0"?>
<root BTCPP_format="4" main_tree_to_execute="t">
  <BehaviorTree ID="t">
    <Sequence name="s">
      <SubTree ID="grip" name="hold on" torque="{given}"/>
      <clamp name="rear" half="rear" torque="{rear}"/>
      <wait name="rest" duration="1 s"/>
    </Sequence>
  </BehaviorTree>
  <BehaviorTree ID="grip">
    <clamp name="front" half="front" torque="{torque}"/>
  </BehaviorTree>
  <TreeNodesModel>
    <SubTree ID="grip"><input_port name="torque" type="torque"/></SubTree>
  </TreeNodesModel>
</root>
"""


def _import(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], given: str, rear: str, *more: str
) -> tuple[int, list[str]]:
    source = tmp_path / "t.xml"
    source.write_text(XML.replace("{given}", given).replace("{rear}", rear), encoding="utf-8")
    code = main(["import", "btcpp", str(source), "-o", str(tmp_path / "t.yaml"), *more])
    return code, capsys.readouterr().err.splitlines()


def test_a_torque_over_the_robot_s_limit_is_refused_at_its_xml_element(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code, errors = _import(tmp_path, capsys, "0.5 N*m", "50 N*m")
    assert code == 2
    assert errors == [
        f"pirate-bt: {tmp_path / 't.xml'}:6:7: clamp: torque: 50 N*m is above the bend"
        " joints' limit 0.8 N*m"
    ]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["t.xml"]  # nothing written


def test_every_problem_is_reported_in_the_xml_a_subtree_s_too(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code, errors = _import(tmp_path, capsys, "50 N*m", "0.9 N*m")
    assert code == 2
    where = [line.split(": ", 2)[1] for line in errors]
    # the subtree's value is the call's: reported at the call (5:7), naming its use
    assert where == [f"{tmp_path / 't.xml'}:5:7", f"{tmp_path / 't.xml'}:6:7"]
    assert all("above the bend joints' limit" in line for line in errors)
    assert errors[0].endswith(f"(used at {tmp_path / 't.xml'}:11:5)")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["t.xml"]


def test_units_and_node_types_are_checked_at_their_xml_element(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code, errors = _import(tmp_path, capsys, "0.5 N*m", "0.5")
    assert code == 2 and errors[0].endswith("t.xml:6:7: clamp: torque: '0.5' needs a unit:"
                                            " write it as e.g. '0.5 N*m'")  # fmt: skip
    source = tmp_path / "t.xml"
    source.write_text(
        XML.replace("{given}", "0.5 N*m")
        .replace("{rear}", "0.5 N*m")
        .replace('<wait name="rest"', '<wiat name="rest"'),
        encoding="utf-8",
    )
    assert main(["import", "btcpp", str(source), "-o", str(tmp_path / "t.yaml")]) == 2
    assert "t.xml:7:7: unknown node type 'wiat'" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["t.xml"]


def test_a_tree_that_fits_the_robot_is_written(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    robot = str(ROOT / "hardware" / "pirate.yaml")
    code, _ = _import(tmp_path, capsys, "0.5 N*m", "0.7 N*m", "--robot", robot)
    assert code == 0
    assert (tmp_path / "t.yaml").is_file()


def test_the_api_raises_every_problem_located(tmp_path: Path) -> None:
    source = tmp_path / "t.xml"
    source.write_text(XML.replace("{given}", "50 N*m").replace("{rear}", "9 N*m"), "utf-8")
    with pytest.raises(ValidationFailed) as raised:
        import_xml(source, tmp_path / "t.yaml")
    assert [(e.location.file, e.location.line) for e in raised.value.errors] == [
        (str(source), 5),
        (str(source), 6),
    ]
    assert not (tmp_path / "t.yaml").exists()
