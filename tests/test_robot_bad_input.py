"""A corpus of malformed robot descriptions: each gives its located error and exit 2.

Most cases are one edit of the good file, so the expected line is found from an
anchor text in the edited file rather than hard-coded.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import pytest

from pirate_bt.cli import main
from pirate_bt.errors import ValidationFailed
from pirate_bt.robot import load_robot

GOOD = (Path(__file__).resolve().parent.parent / "hardware" / "pirate.yaml").read_text()


@dataclass(frozen=True)
class Case:
    name: str
    old: str | None  # text to replace in the good file (None: use `new` as the whole file)
    new: str
    anchor: str | None  # the error's line holds this text (None: line 1)
    message: str
    column: int | None = None


CASES = [
    Case("yaml-syntax", "  baud: 115200", "  baud: [115200", "state_period", "YAML syntax error"),
    Case("tab-indent", "  baud: 115200", "\tbaud: 115200", "\tbaud", "YAML syntax error"),
    Case(
        "wrong-type",
        "  baud: 115200",
        "  baud: fast",
        "baud: fast",
        "baud: must be a whole number, not 'fast'",
    ),
    Case(
        "unknown-top-key",
        "schema_version: 1",
        "schema_version: 1\ncolour: red",
        "colour",
        "unknown key 'colour'",
        1,
    ),
    Case(
        "unknown-motor-key",
        "        name: camera_pan\n",
        "        name: camera_pan\n        gear: 3\n",
        "gear: 3",
        "unknown key 'gear'",
        9,
    ),
    Case(
        "duplicate-board",
        "  - id: 23\n",
        "  - id: 22\n",
        "id: 22\n    module: bend_2",
        "duplicate board id 22",
        5,
    ),
    Case(
        "limit-outside-raw",
        "torque: {max: 0.8 N*m",
        "torque: {max: 2 N*m",
        "max: 2 N*m",
        "torque limit 2 lies outside the torque mode's raw range",
    ),
    Case(
        "missing-bend-pair",
        "  - {name: bend_4, role: bend, half: rear, length: 65 mm, wheel_radius: 12 mm,"
        " assumption: true}\n",
        "",
        "modules:",
        "the rear half needs its bend pair",
    ),
    Case(
        "unknown-unit",
        "length: 90 mm, assumption",
        "length: 90 furlong, assumption",
        "90 furlong",
        "unknown unit 'furlong'",
    ),
    Case(
        "wrong-dimension",
        "lever_arm: 40 mm",
        "lever_arm: 40 deg",
        "lever_arm",
        "is an angle, but a length is expected",
    ),
    Case("missing-unit", "lever_arm: 40 mm", "lever_arm: 40", "lever_arm", "needs a unit"),
    Case(
        "duplicate-key",
        "  baud: 115200",
        "  baud: 115200\n  baud: 9600",
        "baud: 9600",
        "duplicate key 'baud'",
    ),
    Case(
        "unknown-module",
        "    module: bend_2\n",
        "    module: bend_9\n",
        "module: bend_9",
        "unknown module 'bend_9'",
    ),
    Case(
        "duplicate-motor-name",
        "name: bend_2_joint}",
        "name: bend_1_joint}",
        "name: bend_1_joint}",
        "duplicate name 'bend_1_joint'",
    ),
    Case(
        "slot-out-of-range", "        name: camera_pan\n", "        name: camera_pan\n", None, ""
    ),  # placeholder replaced below
    Case(
        "missing-section",
        "bridge:\n  baud: 115200\n  state_period: 10 ms\n  watchdog: 250 ms\n  reset_time: 1.5 s",
        "",
        "schema_version",
        "missing required key 'bridge'",
    ),
    Case("root-is-list", None, "- boards\n- modules\n", None, "must be a mapping"),
    Case(
        "raw-range-reversed",
        "raw: [0, 1023], per_raw: 4 mA",
        "raw: [1023, 0], per_raw: 4 mA",
        "raw: [1023, 0]",
        "must be increasing",
    ),
    Case(
        "imu-range-reversed",
        "raw: [-31416, 31416]",
        "raw: [31416, -31416]",
        "raw: [31416",
        "must be increasing",
    ),
    Case(
        "zero-raw-outside",
        "  zero_raw: 2048",
        "  zero_raw: 9000",
        "zero_raw: 9000",
        "zero_raw 9000 lies outside",
    ),
    Case("unknown-role", "role: rotational", "role: spinner", "role: spinner", "role:"),
    Case(
        "joint-without-position-mode",
        "    position: {raw: [-2048, 2047], per_raw: 0.087890625 deg}\n  drive_motor",
        "  drive_motor",
        "modes: *joint_modes\n        limits:\n          angle: {min: -110",
        "needs a position mode",
    ),
    Case(
        "contact-angles-unsorted",
        "{diameter: 80 mm, angle: 1.58 rad}",
        "{diameter: 50 mm, angle: 1.58 rad}",
        "diameter: 50 mm",
        "sorted by increasing",
    ),
    Case(
        "two-rotational",
        "{name: bend_3, role: bend, half: rear",
        "{name: bend_3, role: rotational, half: null",
        "modules:",
        "exactly one rotational module",
    ),
    Case(
        "duplicate-sensor-slot",
        "slot: 1, name: bend_1_spring",
        "slot: 0, name: bend_1_spring",
        "name: bend_1_spring",
        "sensor slot 0 used twice",
    ),
    # pydantic's words were "Input tag 'gyro' found using 'kind' does not match any of the
    # expected tags: <SensorKind.ANGLE: 'angle'>, ...", at the sensor, not its kind
    Case(
        "unknown-sensor-kind",
        "        kind: imu\n",
        "        kind: gyro\n",
        "kind: gyro",
        "kind: 'gyro' is not one of angle, spring, imu",
        9,
    ),
    # was "Unable to extract tag using discriminator 'kind'"
    Case(
        "missing-sensor-kind",
        "        name: imu\n        kind: imu\n",
        "        name: imu\n",
        "slot: 0\n        name: imu",
        "missing required key 'kind'",
        9,
    ),
    Case("bad-name", "name: rear_leds", "name: Rear-LEDs", "Rear-LEDs", "pattern"),
    Case("negative-period", "period: 20 ms", "period: 20 ms", None, ""),  # placeholder
]
CASES = [c for c in CASES if c.message]  # drop placeholders
CASES.append(
    Case(
        "slot-out-of-range",
        "      - slot: 1\n        name: camera_pan",
        "      - slot: 2\n        name: camera_pan",
        "slot: 2",
        "slot: must be at most 1, not 2",
    )
)
CASES.append(
    Case(
        "negative-friction",
        "friction_coefficient: 0.6",
        "friction_coefficient: -0.6",
        "friction_coefficient",
        "friction_coefficient: must be more than 0, not -0.6",
    )
)


def _write(tmp_path: Path, case: Case) -> tuple[Path, int]:
    if case.old is None:
        text = case.new
    else:
        assert case.old in GOOD, f"{case.name}: edit anchor not in the good file"
        text = GOOD.replace(case.old, case.new, 1)
    path = tmp_path / f"{case.name}.yaml"
    path.write_text(text, encoding="utf-8")
    line = 1
    if case.anchor is not None:
        index = text.index(case.anchor)
        line = text.count("\n", 0, index) + 1
    return path, line


def test_corpus_is_large_enough() -> None:
    assert len(CASES) >= 20
    assert len({c.name for c in CASES}) == len(CASES)


@pytest.mark.parametrize("case", CASES, ids=lambda c: c.name)
def test_malformed_description_is_located(
    case: Case, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path, line = _write(tmp_path, case)
    with pytest.raises(ValidationFailed) as info:
        load_robot(path)
    text = "\n".join(str(e) for e in info.value.errors)
    assert case.message in text
    first = next(e for e in info.value.errors if case.message in str(e))
    assert first.location.file == str(path)
    assert first.location.line == line, text
    if case.column is not None:
        assert first.location.column == case.column, text
    # The command line says the same in one line per error, exit code 2, no traceback.
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr().err
    assert re.search(rf"^{re.escape(str(path))}:{line}:\d+: ", err, re.M), err
    assert "Traceback" not in err


@pytest.mark.parametrize("kind", ["empty", "directory", "binary", "not-utf8", "missing"])
def test_files_that_are_not_yaml_text(
    kind: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / f"{kind}.yaml"
    expected = {
        "empty": "file is empty",
        "directory": "is a directory",
        "binary": "binary file",
        "not-utf8": "not UTF-8 text (byte 0xff)",
        "missing": "no such file",
    }[kind]
    if kind == "empty":
        path.write_text("")
    elif kind == "directory":
        path.mkdir()
    elif kind == "binary":
        path.write_bytes(b"\x7fELF\x00\x01\x02")
    elif kind == "not-utf8":
        path.write_bytes(b"name: caf\xff\n")
    assert main(["validate", "--kind", "hardware", str(path)]) == 2
    err = capsys.readouterr().err
    assert f"{path}:" in err and expected in err
    if kind == "not-utf8":
        assert f"{path}:1:10:" in err
    assert "Traceback" not in err


@pytest.mark.parametrize(
    ("old", "new", "again", "first"),
    [
        ("  - id: 23\n", "  - id: 22\n", "duplicate board id 22", "  - id: 22\n"),
        (
            "name: bend_2_joint}",
            "name: bend_1_joint}",
            "duplicate name 'bend_1_joint'",
            "name: bend_1_joint\n",
        ),
        ("name: bend_2, role", "name: bend_1, role", "duplicate module name", "name: bend_1, "),
    ],
)
def test_a_duplicate_names_its_first_place(
    old: str, new: str, again: str, first: str, tmp_path: Path
) -> None:
    # was "duplicate board id 22 (also boards[2])": a path into the data, not a place
    text = GOOD.replace(old, new, 1)
    path = tmp_path / "dup.yaml"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(ValidationFailed) as info:
        load_robot(path)
    error = next(e for e in info.value.errors if again in str(e))
    at = text.index(first)
    line = text.count("\n", 0, at) + 1
    column = at - text.rfind("\n", 0, at) + len(first) - len(first.lstrip(" -"))
    assert f" (first at {path}:{line}:{column})" in str(error), str(error)
    assert error.location.line > line


def test_a_duplicate_built_in_python_names_its_first_place_by_path() -> None:
    from pirate_bt.robot.description import RobotDescription
    from pirate_bt.yamlfile import load_yaml_text

    data = load_yaml_text(GOOD.replace("  - id: 23\n", "  - id: 22\n", 1)).data
    with pytest.raises(ValueError, match=r"duplicate board id 22 \(first at boards\[2\]\.id\)"):
        RobotDescription.model_validate(data, context={"units_required": True})
