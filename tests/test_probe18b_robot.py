"""Probe 18b: a lab's own PIRATE variant, a copy of hardware/pirate.yaml edited.

Each test edits the bundled robot the way someone describing their own robot
would, and checks what `pirate-bt validate` tells them: a description no run can
drive correctly is refused in one line at the key to change, and the legitimate
edit next to it still validates.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt import simulate_tree
from pirate_bt.cli import main
from pirate_bt.errors import ValidationFailed
from pirate_bt.robot import load_robot

GOOD = (Path(__file__).resolve().parent.parent / "hardware" / "pirate.yaml").read_text()
FEEDBACK_VELOCITY = "      velocity: {raw: [-1200, 1200], per_raw: 0.1 mm/s}\n      current"
FEEDBACK_CURRENT = "      current: {raw: [0, 1023], per_raw: 4 mA}"
SPRING_SCALE = "    per_raw: 50 mN"


def variant(tmp_path: Path, *edits: tuple[str, str]) -> Path:
    """A copy of the bundled robot with each ``(old, new)`` replaced once."""
    text = GOOD
    for old, new in edits:
        assert text.count(old) == 1, old
        text = text.replace(old, new, 1)
    path = tmp_path / "my-robot.yaml"
    path.write_text(text, encoding="utf-8")
    return path


def where(path: Path, anchor: str) -> str:
    """``path:line:column`` of the only line holding ``anchor``, at its first non-blank."""
    found = [
        (n, line.index(anchor.lstrip()) + 1)
        for n, line in enumerate(path.read_text().splitlines(), 1)
        if anchor in line
    ]
    assert len(found) == 1, (anchor, found)
    return f"{path}:{found[0][0]}:{found[0][1]}"


def refusal(path: Path, capsys: pytest.CaptureFixture[str]) -> list[str]:
    """The lines `pirate-bt validate` prints for a refused file (exit 2)."""
    assert main(["validate", str(path)]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    with pytest.raises(ValidationFailed):
        load_robot(path)
    return lines


def accepted(path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["validate", str(path)])
    out = capsys.readouterr()
    assert code == 0, out.err


# -- a spring sensor whose range only reaches the clamp force as a negative number ----


def test_a_spring_sensor_with_a_negative_scale_on_a_positive_raw_range_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # raw 0..1023 at -50 mN reads 0 .. -51 N: a pressing wheel's (positive) force
    # saturates at 0 N, so no clamp is ever confirmed and every run times out
    # clamping; the check compared the range's magnitude (51 N) and let it pass
    path = variant(tmp_path, (SPRING_SCALE, "    per_raw: -50 mN"))
    lines = refusal(path, capsys)
    assert len(lines) == 4  # one per bend module, each at the sensor's raw range
    assert lines[0].startswith(where(path, "    raw: [0, 1023]") + ": ")
    assert "spring sensor of 'bend_1' reads at most 0 N" in lines[0]
    assert "8.75 N" in lines[0]


def test_a_reversed_spring_sensor_reading_the_force_positive_validates(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = variant(
        tmp_path,
        ("    raw: [0, 1023]\n    per_raw: 50 mN", "    raw: [-1023, 0]\n    per_raw: -50 mN"),
    )
    accepted(path, capsys)


# -- a drive's velocity feedback that saturates below the speed it is driven at -------


@pytest.mark.parametrize(
    ("feedback", "reads"),
    [
        ("{raw: [-1200, 1200], per_raw: 0.05 mm/s}", "reads -60 .. 60 mm/s"),  # too coarse
        ("{raw: [0, 1200], per_raw: 0.1 mm/s}", "reads 0 .. 120 mm/s"),  # forward only
    ],
)
def test_a_velocity_feedback_that_cannot_read_the_commanded_speed_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], feedback: str, reads: str
) -> None:
    # with feedback reading at most 60 mm/s, a drive at 80 mm/s counted 3/4 of the
    # distance it drove: the bend-right mission "believed at 3.88 m, truly 4.06 m"
    path = variant(
        tmp_path,
        (FEEDBACK_VELOCITY, f"      velocity: {feedback}\n      current"),
    )
    lines = refusal(path, capsys)
    assert len(lines) == 6  # every drive, at the template's feedback velocity raw range
    at = where(path, f"      velocity: {feedback}").rsplit(":", 1)[0]
    assert lines[0].startswith(f"{at}:18: velocity feedback of 'bend_1_drive' {reads}")
    assert "commanded -100 .. 100 mm/s" in lines[0]
    assert "under-count the distance" in lines[0]


def test_a_velocity_feedback_that_reads_the_limited_speed_validates(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # reads +-100 mm/s: the drive's limit, though its mode could be asked for 120
    path = variant(
        tmp_path,
        (
            FEEDBACK_VELOCITY,
            "      velocity: {raw: [-1000, 1000], per_raw: 0.1 mm/s}\n      current",
        ),
    )
    accepted(path, capsys)


# -- a drive's current feedback that cannot read what a blocked wheel draws -----------


@pytest.mark.parametrize(
    ("feedback", "reads"),
    [
        ("{raw: [0, 1023], per_raw: 1 mA}", "reads at most 1.02 A"),  # mA per step mistaken
        ("{raw: [0, 1023], per_raw: -4 mA}", "reads at most 0 A"),  # reversed on a 0.. range
    ],
)
def test_a_current_feedback_that_cannot_read_a_stall_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], feedback: str, reads: str
) -> None:
    # a blocked wheel draws motion.drive_stall_current (1.5 A) and a drive tells a
    # stall by 0.8 of it: a reading stuck at 1.02 A (or 0 A) never showed one, and the
    # bend-right mission timed out after 120 s pushing the front half into the turn
    path = variant(tmp_path, (FEEDBACK_CURRENT, f"      current: {feedback}"))
    lines = refusal(path, capsys)
    assert len(lines) == 6  # every drive, at the template's feedback current raw range
    at = where(path, f"      current: {feedback}").rsplit(":", 1)[0]
    assert lines[0].startswith(f"{at}:17: current feedback of 'bend_1_drive' {reads},")
    assert "motion.drive_stall_current 1.5 A" in lines[0]


def test_a_current_feedback_that_reads_the_stall_current_validates(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = variant(
        tmp_path,
        (FEEDBACK_CURRENT, "      current: {raw: [0, 1023], per_raw: 1 mA}"),
        ("drive_stall_current: 1.5 A", "drive_stall_current: 1 A"),
    )
    accepted(path, capsys)


# -- a cruise speed the drives may not go ---------------------------------------------


def test_a_nominal_speed_above_the_drives_limit_is_refused_at_the_nominal_speed(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # every mission on it was refused when it loaded, placed at "<dict>:1:1" (a
    # parameter of the planned tree), never at the robot file's line
    path = variant(tmp_path, ("nominal_speed: 80 mm/s", "nominal_speed: 150 mm/s"))
    lines = refusal(path, capsys)
    assert lines == [
        f"{where(path, 'nominal_speed: 150 mm/s')}: nominal_speed 150 mm/s is faster than"
        " drive 'bend_1_drive' may go (100 mm/s, its velocity mode and limit): a mission"
        " drives at the nominal speed, and every one would be refused when it loads"
    ]


def test_a_nominal_speed_at_the_drives_limit_validates(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    accepted(variant(tmp_path, ("nominal_speed: 80 mm/s", "nominal_speed: 100 mm/s")), capsys)


# -- a joint motor and the angle sensor the host reads it by, on different slots ------

BEND_2 = (
    "      - {<<: *bend_motor, name: bend_2_joint}\n"
    "      - {<<: *drive_motor, slot: 1, name: bend_2_drive}\n"
    "    sensors:\n"
    "      - {<<: *angle_sensor, slot: 0, name: bend_2_angle}\n"
    "      - {<<: *spring_sensor, slot: 1, name: bend_2_spring}"
)


def test_a_bend_joint_whose_angle_sensor_is_on_the_other_slot_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # the board closes the joint's loop on the angle sensor of its own slot (and the
    # simulator feeds that sensor the joint's angle): with the sensors swapped the
    # host read 0 deg while the joint pressed, and every front clamp timed out
    swapped = BEND_2.replace("slot: 0, name: bend_2_angle", "slot: 1, name: bend_2_angle")
    swapped = swapped.replace("slot: 1, name: bend_2_spring", "slot: 0, name: bend_2_spring")
    path = variant(tmp_path, (BEND_2, swapped))
    lines = refusal(path, capsys)
    assert lines == [
        f"{where(path, '        slot: 0')}: bend joint 'bend_2_joint' of 'bend_2' (board 23,"
        " slot 0): its board has no angle sensor on slot 0; the board closes the joint's"
        " position loop on the angle sensor of the joint's own slot: put the module's angle"
        " sensor there"
    ]


def test_a_rotate_motor_on_the_board_without_the_rotation_sensor_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # a second rotate motor on board 24 (whose slot 0 is the IMU) became the one the
    # host drives: "timeout: not done after 10 s (rotating to 90.0 deg: at 0.0 deg)"
    drive_a = "      - {<<: *drive_motor, slot: 1, name: rotational_drive_a}"
    path = variant(
        tmp_path,
        (drive_a, f"      - {{<<: *bend_motor, name: rotate_b, function: rotate}}\n{drive_a}"),
    )
    lines = refusal(path, capsys)
    assert len(lines) == 1
    assert (
        "rotate joint 'rotate_b' of 'rotational' (board 24, slot 0): its board has no" in (lines[0])
    )


def test_a_second_angle_sensor_read_before_the_joints_own_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    extra = (
        "  - id: 19\n    module: bend_1\n    sensors:\n"
        "      - {<<: *angle_sensor, slot: 0, name: bend_1_extra}\n\n  - id: 23\n"
    )
    path = variant(tmp_path, ("  - id: 23\n", extra))
    lines = refusal(path, capsys)
    assert len(lines) == 1
    assert (
        "the host reads the joint from 'bend_1_extra', the module's first angle sensor,"
        " not from 'bend_1_angle' on the joint's slot" in lines[0]
    )


def test_a_bend_board_wired_the_other_way_round_validates_and_clamps(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # the joint and its angle sensor on slot 1, the drive and the spring on slot 0
    mirrored = (
        "      - {<<: *bend_motor, slot: 1, name: bend_2_joint}\n"
        "      - {<<: *drive_motor, slot: 0, name: bend_2_drive}\n"
        "    sensors:\n"
        "      - {<<: *angle_sensor, slot: 1, name: bend_2_angle}\n"
        "      - {<<: *spring_sensor, slot: 0, name: bend_2_spring}"
    )
    path = variant(tmp_path, (BEND_2, mirrored))
    accepted(path, capsys)
    result = simulate_tree("straight", robot=path, network="straight", params={"distance": "0.2 m"})
    assert result.status == "success", result.why
    assert result.counters.violations == 0


# -- a bridge watchdog that outlasts the host's patience ------------------------------


def test_a_watchdog_longer_than_the_link_silence_limit_is_refused_at_the_watchdog(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # on a lost link the host gave up (exit 3) after 0.5 s, "the robot may still be
    # moving until its bridge's watchdog stops it": here a minute later
    path = variant(tmp_path, ("watchdog: 250 ms", "watchdog: 60 s"))
    lines = refusal(path, capsys)
    assert lines == [
        f"{where(path, 'watchdog: 60 s')}: watchdog 60000 ms is longer than"
        " safety.max_link_silence 500 ms: on a lost link the host gives up after 500 ms,"
        " and the bridge alone can stop the wheels, after 60000 ms; the robot would drive"
        " on blind meanwhile (make the watchdog no longer than the silence limit)"
    ]


def test_a_watchdog_as_long_as_the_link_silence_limit_validates(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    accepted(variant(tmp_path, ("watchdog: 250 ms", "watchdog: 500 ms")), capsys)
