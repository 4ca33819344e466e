"""The command line: help, validate, schema, robot, demo, exit codes."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from pirate_bt.cli import COMMANDS, main
from pirate_bt.robot.reference import render_reference

REPO = Path(__file__).resolve().parent.parent


def test_module_entry_point_prints_help() -> None:
    done = subprocess.run(
        [sys.executable, "-m", "pirate_bt", "--help"], capture_output=True, text=True, check=False
    )
    assert done.returncode == 0
    for verb in COMMANDS:
        assert verb in done.stdout


def test_no_command_is_a_usage_error(capsys: pytest.CaptureFixture[str]) -> None:
    assert main([]) == 2
    assert "usage" in capsys.readouterr().err


def test_unknown_command_and_bad_option_exit_2(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["frobnicate"]) == 2  # returned, as every other usage error is
    assert main(["validate", "--no-such-option", "x"]) == 2
    capsys.readouterr()


def test_validate_good_files(capsys: pytest.CaptureFixture[str]) -> None:
    files = [REPO / "hardware/pirate.yaml", *sorted((REPO / "hardware/variants").glob("*.yaml"))]
    assert main(["validate", *map(str, files)]) == 0
    out = capsys.readouterr().out
    assert out.count(": ok") == len(files)


def test_validate_mixed_files_reports_every_bad_one(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text("boards: []\n")
    unknown = tmp_path / "what.yaml"
    unknown.write_text("colour: red\n")
    assert main(["validate", str(REPO / "hardware/pirate.yaml"), str(bad), str(unknown)]) == 2
    captured = capsys.readouterr()
    assert "hardware/pirate.yaml: ok" in captured.out
    assert f"{bad}:1:1: missing required key 'name'" in captured.err
    assert f"{unknown}:1:1: cannot tell what kind of file this is" in captured.err


def test_schema_hardware_is_json_schema(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["schema", "hardware"]) == 0
    schema = json.loads(capsys.readouterr().out)
    assert schema["$schema"].endswith("2020-12/schema")
    assert {"modules", "boards", "clamp"} <= set(schema["properties"])
    assert schema["additionalProperties"] is False


def test_robot_prints_the_board_table(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["robot"]) == 0
    out = capsys.readouterr().out
    assert "22     bend_1" in out and "bend_1_joint (bend)" in out
    assert out.count("\n") >= 11


def test_robot_draw_writes_dot_even_without_graphviz(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    import shutil

    monkeypatch.setattr(shutil, "which", lambda name: None)
    assert main(["robot", "--draw", str(tmp_path / "r.svg")]) == 0
    assert "Graphviz 'dot' is not installed" in capsys.readouterr().err
    assert (tmp_path / "r.dot").read_text().startswith("digraph robot")
    assert not (tmp_path / "r.svg").exists()


@pytest.mark.skipif(not __import__("shutil").which("dot"), reason="Graphviz dot not installed")
def test_robot_draws_every_module_as_svg(tmp_path: Path) -> None:
    import xml.etree.ElementTree as ET

    assert main(["robot", "--draw", str(tmp_path / "robot.svg")]) == 0
    svg = ET.parse(tmp_path / "robot.svg").getroot()
    text = " ".join(t.text or "" for t in svg.iter() if t.tag.endswith("text"))
    for module in ("front", "bend_1", "rotational", "bend_4", "rear"):
        assert module in text
    assert "board 25" in text and (tmp_path / "robot.dot").exists()


def test_internal_errors_are_one_line(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    import pirate_bt.cli.validate as validate

    def boom(*_: object, **__: object) -> None:
        raise RuntimeError("kaboom")

    monkeypatch.setattr(validate, "validate_file", boom)
    assert main(["validate", "x.yaml"]) == 1
    err = capsys.readouterr().err
    assert "internal error: RuntimeError: kaboom" in err and "Traceback" not in err


def test_reference_page_is_in_step_with_the_schema() -> None:
    page = (REPO / "docs/reference/robot-description.md").read_text(encoding="utf-8")
    assert page == render_reference(), (
        "docs/reference/robot-description.md is stale: run "
        "'python -m pirate_bt.robot.reference > docs/reference/robot-description.md'"
    )


@pytest.mark.parametrize("kind", sorted(__import__("pirate_bt.filekinds").filekinds.KINDS))
def test_every_file_kind_has_a_schema(kind: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["schema", kind]) == 0
    schema = json.loads(capsys.readouterr().out)
    assert isinstance(schema, dict) and schema


def test_validate_detects_traces_by_suffix(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    good = REPO / "tests/data/traces/pab_v1.jsonl"
    bad = tmp_path / "bad.jsonl"
    bad.write_text('{"bad": 1}\n')
    assert main(["validate", str(good)]) == 0
    assert main(["validate", str(bad)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"{bad}:1:1: not a trace record")
    assert err.count(str(bad)) == 1


def test_bundled_trees_and_routes_are_found_by_name(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from pirate_bt.resources import find_file

    monkeypatch.chdir(tmp_path)  # outside the repository, as an installed library is
    assert find_file("trees", "bend.yaml") == REPO / "trees" / "bend.yaml"
    assert find_file("scenarios", "lab.route") == REPO / "scenarios" / "lab.route"
    (tmp_path / "bend.yaml").write_text("mine")
    assert find_file("trees", "bend.yaml") == Path("bend.yaml")  # a real file wins
    assert find_file("trees", "nope.yaml") == Path("nope.yaml")
    assert find_file("trees", "sub/bend.yaml") == Path("sub/bend.yaml")
