"""Robot descriptions whose policy values validated but cannot work (session 23): a
slope limit past 90 deg, an alignment tolerance that counts every roll as aligned, a
release force no smaller than a clamp's, sensor readings trusted for longer than a
silent link. ``pirate-bt validate`` refuses each in one line at the key to change,
with the range accepted, exit 2; the bundled robots still validate."""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.cli import main
from pirate_bt.errors import ValidationFailed
from pirate_bt.robot import load_robot

HARDWARE = Path(__file__).resolve().parent.parent / "hardware"
GOOD = (HARDWARE / "pirate.yaml").read_text()


def _variant(tmp_path: Path, old: str, new: str) -> Path:
    assert GOOD.count(old) == 1, old
    path = tmp_path / "my-robot.yaml"
    path.write_text(GOOD.replace(old, new), encoding="utf-8")
    return path


CASES = [
    # (old, new, line anchor, column, the message's start, the range it gives)
    (
        "max_unclamped_slope: 10 deg",
        "max_unclamped_slope: 120 deg",
        "max_unclamped_slope:",
        3,
        "max_unclamped_slope 120 deg is no slope a pipe has",
        "from 0 deg up to, not including, 90 deg",
    ),
    (
        "alignment_tolerance: 8 deg",
        "alignment_tolerance: 90 deg",
        "alignment_tolerance:",
        3,
        "alignment_tolerance 90 deg counts every roll as aligned",
        "above 0 deg and below 90 deg",
    ),
    (
        "release_force_fraction: 0.2",
        "release_force_fraction: 0.95",
        "release_force_fraction:",
        3,
        "release_force_fraction 0.95 is not below clamp_force_fraction 0.9",
        "above 0 and below 0.9",
    ),
    (
        "release_force_fraction: 0.2",
        "release_force_fraction: 0",
        "release_force_fraction:",
        3,
        "release_force_fraction 0 counts no half as free",
        "above 0 and below clamp_force_fraction 0.9",
    ),
    (
        "  spring_sensor: &spring_sensor\n    kind: spring\n    raw: [0, 1023]\n"
        "    per_raw: 50 mN\n    period: 10 ms",
        "  spring_sensor: &spring_sensor\n    kind: spring\n    raw: [0, 1023]\n"
        "    per_raw: 50 mN\n    period: 10 s",
        "period: 10 s",
        5,
        "the readings of sensor 'bend_1_spring' would count as fresh for 100 s"
        " (safety.stale_after_periods 10 x its period 10 s), longer than"
        " safety.max_link_silence 500 ms",
        "give a period of at most 50 ms",
    ),
    (
        "stale_after_periods: 10",
        "stale_after_periods: 100000",
        "    period: 10 ms\n    assumption: true\n  spring_sensor",  # the angle sensors'
        5,
        "the readings of sensor 'camera_tilt_angle' would count as fresh for 1000 s",
        "or a stale_after_periods of at most 50",
    ),
]


@pytest.mark.parametrize(("old", "new", "anchor", "col", "start", "accepted"), CASES)
def test_a_policy_value_that_cannot_work_is_refused_at_its_key(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    old: str,
    new: str,
    anchor: str,
    col: int,
    start: str,
    accepted: str,
) -> None:
    path = _variant(tmp_path, old, new)
    text = path.read_text()
    line = text[: text.index(anchor)].count("\n") + 1
    code = main(["validate", str(path)])
    out = capsys.readouterr()
    lines = (out.out + out.err).splitlines()
    assert code == 2, lines
    assert len(lines) == 1, lines
    assert lines[0].startswith(f"{path}:{line}:{col}: {start}"), lines
    assert accepted in lines[0]
    with pytest.raises(ValidationFailed):
        load_robot(path)


@pytest.mark.parametrize(
    ("old", "new"),
    [
        ("max_unclamped_slope: 10 deg", "max_unclamped_slope: 89 deg"),
        ("alignment_tolerance: 8 deg", "alignment_tolerance: 45 deg"),
        ("release_force_fraction: 0.2", "release_force_fraction: 0.85"),
        ("max_link_silence: 500 ms", "max_link_silence: 250 ms"),
    ],
)
def test_values_inside_the_ranges_still_validate(tmp_path: Path, old: str, new: str) -> None:
    load_robot(_variant(tmp_path, old, new))


def test_the_bundled_robots_validate() -> None:
    for path in [HARDWARE / "pirate.yaml", *sorted((HARDWARE / "variants").glob("*.yaml"))]:
        load_robot(path)
