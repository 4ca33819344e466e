"""Probe 16: robot descriptions that differ from the bundled robot, hostile and legitimate.

Each test edits a copy of hardware/pirate.yaml the way a lab describing its own
PIRATE variant would, and checks what `pirate-bt validate` (or a run) tells it.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.cli import main
from pirate_bt.errors import ValidationFailed
from pirate_bt.robot import load_robot

GOOD = (Path(__file__).resolve().parent.parent / "hardware" / "pirate.yaml").read_text()
IMU = "        per_raw: 0.1 mrad\n"


def variant(tmp_path: Path, *edits: tuple[str, str], name: str = "my-robot.yaml") -> Path:
    """A copy of the bundled robot with each ``(old, new)`` replaced once."""
    text = GOOD
    for old, new in edits:
        assert text.count(old) >= 1, old
        text = text.replace(old, new, 1)
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def line_of(path: Path, anchor: str) -> int:
    """The 1-based line of ``path`` that holds ``anchor`` (the only one)."""
    lines = [i for i, line in enumerate(path.read_text().splitlines(), 1) if anchor in line]
    assert len(lines) == 1, (anchor, lines)
    return lines[0]


def refused(path: Path) -> str:
    """The one-line error ``load_robot`` gives for ``path``."""
    with pytest.raises(ValidationFailed) as info:
        load_robot(path)
    text = str(info.value)
    assert "\n" not in text.strip(), text
    return text


def validate(path: Path, capsys: pytest.CaptureFixture[str]) -> tuple[int, str]:
    code = main(["validate", str(path)])
    out = capsys.readouterr()
    return code, out.out + out.err


# -- IMU axes -------------------------------------------------------------------


@pytest.mark.parametrize(
    ("axes", "words"),
    [
        ("[roll, pitch, heading]", "IMU axis 'heading' is not one of roll, pitch, yaw"),
        ("[roll, roll, yaw]", "an IMU axis is listed twice"),
        ("[]", "an IMU needs at least one axis"),
    ],
)
def test_imu_axes_the_firmware_cannot_read_are_refused_at_the_axes_key(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], axes: str, words: str
) -> None:
    # Before: `validate` said ok; `robot header` then failed with no file or line
    # ("IMU 'imu': axis 'heading' unknown"), a duplicate axis gave two state channels
    # of one name (the second overwrote the first's reading), and no axis left the
    # IMU with no channel at all.
    path = variant(tmp_path, (IMU, IMU + f"        axes: {axes}\n"))
    code, out = validate(path, capsys)
    assert code == 2
    assert f"{path}:{line_of(path, 'axes:')}:9: {words}" in out


def test_imu_with_some_of_the_three_axes_still_loads(tmp_path: Path) -> None:
    robot = load_robot(variant(tmp_path, (IMU, IMU + "        axes: [roll, yaw]\n")))
    imu = robot.imu()
    assert imu is not None and imu.axes == ("roll", "yaw")
    assert [c.name for c in robot.state_channels() if c.name.startswith("imu.")] == [
        "imu.roll",
        "imu.yaw",
    ]


# -- bridge times and the freshness factor ------------------------------------------


@pytest.mark.parametrize(
    ("old", "new", "words"),
    [
        # the host slept this long on opening a real port: a run that never starts
        ("reset_time: 1.5 s", "reset_time: 1e9 s", "reset_time: must be at most 60 s"),
        # the firmware's header refused these, without a file or line, after validate
        ("watchdog: 250 ms", "watchdog: 0.1 ms", "watchdog: must be at least 1 ms"),
        ("state_period: 10 ms", "state_period: 100 min", "state_period: must be at most"),
        # an infinite factor turned the protective layer's freshness check off
        (
            "stale_after_periods: 10",
            "stale_after_periods: .inf",
            "stale_after_periods: must be a finite number, not inf",
        ),
    ],
)
def test_bridge_times_and_freshness_factor_out_of_bounds_are_refused_where_written(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], old: str, new: str, words: str
) -> None:
    path = variant(tmp_path, (old, new))
    code, out = validate(path, capsys)
    assert code == 2
    assert f"{path}:{line_of(path, new.split(':')[0] + ':')}:3: {words}" in out


def test_robot_header_of_a_valid_robot_at_the_bridge_time_bounds(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = variant(
        tmp_path, ("watchdog: 250 ms", "watchdog: 1 ms"), ("reset_time: 1.5 s", "reset_time: 60 s")
    )
    out = tmp_path / "layout.h"
    assert main(["robot", "header", str(path), "-o", str(out)]) == 0
    text = out.read_text()
    assert "#define PB_WATCHDOG_MS 1\n" in text
    assert "#define PB_RESET_TIME_MS 60000\n" in text
