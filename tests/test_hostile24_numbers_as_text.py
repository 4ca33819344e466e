"""Whole numbers and yes/no values of robot descriptions and networks as written.

A robot description took a board's ``id: '20'``, ``slot: true``, ``raw: [false, 4095]``
and ``schema_version: yes`` as the numbers pydantic's lax reading made of them, and
``assumption: 'off'`` as false: text and booleans where a file means a number (and
the other way round) were never refused, where a tree's parameters are. Now each is
one located line, exit 2.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.cli import main

_ROOT = Path(__file__).resolve().parents[1]
_ROBOT = (_ROOT / "hardware" / "pirate.yaml").read_text(encoding="utf-8")
_NETWORK = (_ROOT / "scenarios" / "straight.yaml").read_text(encoding="utf-8")


def _validate(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], text: str
) -> tuple[int, list[str]]:
    path = tmp_path / "file.yaml"
    path.write_text(text, encoding="utf-8")
    code = main(["validate", str(path)])
    err = capsys.readouterr().err
    assert "Traceback" not in err
    return code, err.splitlines()


@pytest.mark.parametrize(
    ("written", "as_text", "message"),
    [
        ("  - id: 20\n", "  - id: '20'\n", "id: must be a whole number, not '20'"),
        ("      - slot: 1\n", "      - slot: true\n", "slot: must be a whole number, not true"),
        ("      - slot: 1\n", "      - slot: '1'\n", "slot: must be a whole number, not '1'"),
        ("zero_raw: 2048", "zero_raw: '2048'", "zero_raw: must be a whole number, not '2048'"),
        ("raw: [0, 4095]", "raw: [false, 4095]", "raw: must be a whole number, not false"),
        ("schema_version: 1", "schema_version: yes", "schema_version: must be a whole number"),
        (
            "drive\n    assumption: true",
            "drive\n    assumption: 'off'",
            "assumption: must be true or false, not 'off'",
        ),
        (
            "drive\n    assumption: true",
            "drive\n    assumption: 1",
            "assumption: must be true or false, not 1",
        ),
    ],
)
def test_a_robot_description_refuses_text_and_booleans_for_numbers(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    written: str,
    as_text: str,
    message: str,
) -> None:
    assert written in _ROBOT
    code, lines = _validate(tmp_path, capsys, _ROBOT.replace(written, as_text, 1))
    assert code == 2
    assert len(lines) == 1, lines
    assert lines[0].startswith(f"{tmp_path / 'file.yaml'}:")
    assert message in lines[0]


@pytest.mark.parametrize("version", ["yes", "true", "'1'"])
def test_a_network_s_schema_version_is_the_number_1(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], version: str
) -> None:
    text = _NETWORK.replace("schema_version: 1", f"schema_version: {version}", 1)
    code, lines = _validate(tmp_path, capsys, text)
    assert code == 2
    assert lines == [
        f"{tmp_path / 'file.yaml'}:3:1: schema_version: must be a whole number, not "
        + ("true" if version != "'1'" else "'1'")
    ]


def test_the_bundled_files_still_validate(capsys: pytest.CaptureFixture[str]) -> None:
    files = [_ROOT / "hardware" / "pirate.yaml", _ROOT / "scenarios" / "straight.yaml"]
    assert main(["validate", *map(str, files)]) == 0, capsys.readouterr().err
