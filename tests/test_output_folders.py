"""Every output of the library makes its missing folder: ``render -o``, ``--trace``,
``--output``, ``survey -o`` did, while ``export btcpp -o`` and ``import btcpp -o``
failed with *No such file or directory*. A refused import leaves no folder behind."""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.cli import main
from pirate_bt.errors import ValidationFailed
from pirate_bt.interop.btcpp import export_xml, import_xml

REPO = Path(__file__).resolve().parent.parent
STRAIGHT = REPO / "trees" / "straight.yaml"


def test_export_makes_the_missing_folder(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "new" / "deeper" / "straight.xml"
    assert main(["export", "btcpp", str(STRAIGHT), "-o", str(out)]) == 0
    assert out.read_text(encoding="utf-8").startswith("<?xml")
    assert f"wrote {out}" in capsys.readouterr().out


def test_import_makes_the_missing_folder(tmp_path: Path) -> None:
    xml = export_xml(STRAIGHT, tmp_path / "straight.xml")
    out = tmp_path / "made" / "here" / "straight.yaml"
    assert main(["import", "btcpp", str(xml), "-o", str(out)]) == 0
    assert "type:" in out.read_text(encoding="utf-8")
    assert not [p.name for p in out.parent.iterdir() if p.name != "straight.yaml"]


def test_a_refused_import_leaves_no_folder(tmp_path: Path) -> None:
    # Converts (the node type exists, its port a reference) but does not load: the
    # reference is bound to nothing.
    xml = tmp_path / "far.xml"
    xml.write_text(
        '<root BTCPP_format="4" main_tree_to_execute="m"><BehaviorTree ID="m">'
        '<drive name="far" velocity="0.02 m/s" distance="{nowhere}"/>'
        "</BehaviorTree></root>",
        encoding="utf-8",
    )
    out = tmp_path / "never" / "made" / "far.yaml"
    with pytest.raises(ValidationFailed):
        import_xml(xml, out)
    assert not (tmp_path / "never").exists()


def test_export_through_a_link_replaces_its_target(tmp_path: Path) -> None:
    target = tmp_path / "real.xml"
    target.write_text("old", encoding="utf-8")
    link = tmp_path / "link.xml"
    link.symlink_to(target)
    export_xml(STRAIGHT, link)
    assert link.is_symlink()
    assert target.read_text(encoding="utf-8").startswith("<?xml")
