"""Probe 16: robot descriptions that differ from the bundled robot, hostile and legitimate.

Each test edits a copy of hardware/pirate.yaml the way a lab describing its own
PIRATE variant would, and checks what `pirate-bt validate` (or a run) tells it.
"""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest

from pirate_bt import simulate_tree
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
    # a 1 ms watchdog needs a line fast enough for ten heartbeats a millisecond in half
    # of it: at 4 Mbaud a heartbeat takes 22.5 us (at 115200 baud validate refuses it)
    path = variant(
        tmp_path,
        ("watchdog: 250 ms", "watchdog: 1 ms"),
        ("reset_time: 1.5 s", "reset_time: 60 s"),
        ("baud: 115200", "baud: 4000000"),
    )
    out = tmp_path / "layout.h"
    assert main(["robot", "header", str(path), "-o", str(out)]) == 0
    text = out.read_text()
    assert "#define PB_WATCHDOG_MS 1\n" in text
    assert "#define PB_RESET_TIME_MS 60000\n" in text


# -- a robot no run can drive is refused at load -------------------------------------

ANGLE_TEMPLATE = "    zero_raw: 2048\n    per_raw: 0.087890625 deg"
SPRING_TEMPLATE = "    raw: [0, 1023]\n    per_raw: 50 mN"


@pytest.mark.parametrize(
    ("edits", "anchor", "words"),
    [
        # a run stopped on "link_silent: no state frame from the bridge for 0.100 s"
        (
            [("state_period: 10 ms", "state_period: 150 ms")],
            "state_period: 150 ms",
            "a state frame every 150 ms is too slow for sensor 'camera_tilt_angle': its"
            " readings count as stale after 100 ms",
        ),
        (
            [("state_period: 10 ms", "state_period: 40 ms"), ("silence: 500 ms", "silence: 40 ms")],
            "max_link_silence: 40 ms",
            "max_link_silence 40 ms is not longer than the state period 40 ms",
        ),
        # every clamp timed out: "clamping rear: bend_3 20.5° 17.5 N"
        (
            [(ANGLE_TEMPLATE, "    zero_raw: 2048\n    per_raw: 0.01 deg")],
            "raw: [0, 4095]",
            "angle sensor of 'bend_1' reads -20.48 .. 20.47 deg, but its joint"
            " 'bend_1_joint' moves -110 .. 110 deg (limits.angle)",
        ),
        # reads 0 .. 360 deg: a joint bent the other way read as 0
        (
            [(ANGLE_TEMPLATE, "    zero_raw: 0\n    per_raw: 0.087890625 deg")],
            "raw: [0, 4095]",
            "angle sensor of 'rotational' reads 0 .. 359.9 deg, but its joint 'rotate'",
        ),
        # every clamp timed out: "clamping rear: bend_3 83.1° 1.0 N"
        (
            [(SPRING_TEMPLATE, "    raw: [0, 1023]\n    per_raw: 1 mN")],
            "raw: [0, 1023]",
            "spring sensor of 'bend_4' reads at most 1.02 N, less than the wall force of a"
            " holding clamp, 8.75 N (clamp.min_torque / clamp.lever_arm)",
        ),
        # every clamp timed out: "clamping rear: bend_3 80.0° 0.0 N, bend_4 80.0° 0.0 N"
        (
            [("angle: {min: -110 deg, max: 110 deg,", "angle: {min: -80 deg, max: 80 deg,")],
            "- {diameter: 63 mm, angle: 1.45 rad}",
            "bend joint 'bend_1_joint' stops at 80 deg (limits.angle), short of the"
            " wall-contact angle 83.08 deg of a 63 mm pipe: no half could clamp in it",
        ),
        # every front clamp timed out: "front tilt 30.0°"
        (
            [("angle: {min: -100 deg, max: 100 deg,", "angle: {min: -30 deg, max: 30 deg,")],
            "angle: {min: -30 deg, max: 30 deg, policy: clip}",
            "front tilt 'front_tilt' stops at 30 deg, short of 61.72 deg"
            " (clamp.front_clear_angle + safety.angle_tolerance)",
        ),
        # every tree with a clamp was refused: 0.7 N*m "above the bend joints' limit
        # 0.3 N*m", 0.3 N*m "below the minimum clamp torque 0.35 N*m"
        (
            [("torque: {max: 0.8 N*m, policy: refuse}", "torque: {max: 0.3 N*m, policy: refuse}")],
            "torque: {max: 0.3 N*m, policy: refuse}",
            "bend joint 'bend_1_joint' presses with at most 0.3 N*m (its torque limit and"
            " mode), less than clamp.min_torque 0.35 N*m: no clamp could hold",
        ),
    ],
)
def test_a_robot_no_run_can_drive_is_refused_by_validate_at_the_key_to_change(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    edits: list[tuple[str, str]],
    anchor: str,
    words: str,
) -> None:
    path = variant(tmp_path, *edits)
    code, out = validate(path, capsys)
    assert code == 2
    line = next(
        i for i, text in enumerate(path.read_text().split("\n"), 1) if text.strip() == anchor
    )
    assert f"{path}:{line}:" in out
    assert words in out, out


@pytest.mark.parametrize(
    "edits",
    [
        # a slower bridge (its sensors still outlast a frame), another wheel
        [
            ("state_period: 10 ms", "state_period: 50 ms"),
            ("wheel_radius: 12 mm", "wheel_radius: 20 mm"),
        ],
        # angle sensors reversed and offset, springs read from the other end
        [
            (ANGLE_TEMPLATE, "    zero_raw: 2100\n    per_raw: -0.087890625 deg"),
            (SPRING_TEMPLATE, "    raw: [0, 1023]\n    zero_raw: 1023\n    per_raw: -50 mN"),
        ],
    ],
)
def test_legitimate_variants_validate_and_pass_a_bend(
    tmp_path: Path, edits: list[tuple[str, str]]
) -> None:
    robot = load_robot(variant(tmp_path, *edits))
    result = simulate_tree("bend", network="bend-right", params={"roll": "90 deg"}, robot=robot)
    assert result.status == "success", result.why


# -- out of scope (task/): a mission on a slower robot -------------------------------


def test_a_mission_on_a_slower_robot_drives_at_its_nominal_speed(tmp_path: Path) -> None:
    # pirate_bt/task/tree.py passed a speed to a leg's PAB only when it differed from
    # motion.nominal_speed, so legs at the robot's cruise speed ran at the trees' default
    # 80 mm/s: on a robot whose drives stop at 50 mm/s the mission was refused
    # (drive: velocity: 80 mm/s is above bend_1_drive's limit 50 mm/s)
    from pirate_bt import simulate_mission

    path = variant(
        tmp_path,
        ("nominal_speed: 80 mm/s", "nominal_speed: 40 mm/s"),
        ("velocity: {max: 100 mm/s, policy: clip}", "velocity: {max: 50 mm/s, policy: clip}"),
    )
    result = simulate_mission("bend-right", robot=load_robot(path))
    assert result.status == "success", result.why


# -- the firmware header of a lab's own file -----------------------------------------

FIRMWARE = Path(__file__).resolve().parent.parent / "firmware" / "piratebay"


def test_robot_header_of_a_file_with_a_non_ascii_name_is_written(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # Before: "pirate-bt: internal error: UnicodeEncodeError: 'ascii' codec can't
    # encode character '\xe9'" (exit 1), so `make firmware ROBOT=robot-modifié.yaml` failed.
    path = variant(tmp_path, name="robot-modifié.yaml")
    out = tmp_path / "layout.h"
    assert main(["robot", "header", str(path), "-o", str(out)]) == 0
    assert "robot-modifi?.yaml" in out.read_text(encoding="ascii").splitlines()[0]


@pytest.mark.skipif(shutil.which("avr-gcc") is None, reason="avr-gcc missing (make firmware)")
def test_robot_header_compiles_with_a_trigraph_in_the_name_and_a_comment_end_in_the_path(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # Before: the firmware's -std=c11 -Werror build failed on "trigraph ??! converted to
    # |" (a robot named "... (rev B??!)"), and a path with "*/" closed the header's
    # first comment early (a folder named "we*").
    folder = tmp_path / "we*"
    folder.mkdir()
    path = variant(folder, ("name: PIRATE 2018", 'name: "PIRATE 2018 (rev B??!) */"'))
    out = tmp_path / "layout.h"
    assert main(["robot", "header", str(path), "-o", str(out)]) == 0
    assert '#define PB_ROBOT_NAME "PIRATE 2018 (rev B\\?\\?!) */"' in out.read_text()
    flags = ["-mmcu=atmega2560", "-DF_CPU=16000000UL", "-std=c11", "-Wall", "-Wextra"]
    compiled = subprocess.run(
        [
            "avr-gcc",
            *flags,
            "-Werror",
            "-fsyntax-only",
            f"-I{tmp_path}",
            f"-I{FIRMWARE}",
            str(FIRMWARE / "robot_layout.c"),
        ],
        capture_output=True,
        text=True,
        check=False,
    )
    assert compiled.returncode == 0, compiled.stderr


FEEDBACK = "    feedback:\n      velocity: {raw: [-1200, 1200], per_raw: 0.1 mm/s}"


@pytest.mark.parametrize(
    ("per_raw", "words"),
    [
        # a reversed encoder: the PICO's uint16 read 65436 um/s, a speed 650 times off
        ("-0.1 mm/s", "not -100 um/s"),
        # rounded to 0, which the PICO takes as "no feedback": it reported 0 m/s for ever
        ("0.4 um/s", "not 0.4 um/s"),
    ],
)
def test_robot_header_refuses_a_velocity_feedback_the_pico_table_cannot_hold(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], per_raw: str, words: str
) -> None:
    new = FEEDBACK.replace("per_raw: 0.1 mm/s", f"per_raw: {per_raw}")
    edits = [(FEEDBACK, new)]
    if per_raw == "0.4 um/s":
        # int16 steps of 0.4 um/s read at most 13 mm/s: a robot whose drives go no faster
        # (validate refuses a feedback that cannot read the drives' speed, e5c80c7)
        edits = [
            (FEEDBACK, new.replace("raw: [-1200, 1200]", "raw: [-32768, 32767]")),
            ("velocity: {max: 100 mm/s, policy: clip}", "velocity: {max: 10 mm/s, policy: clip}"),
            ("nominal_speed: 80 mm/s", "nominal_speed: 10 mm/s"),
        ]
    path = variant(tmp_path, *edits)
    out = tmp_path / "layout.h"
    assert main(["robot", "header", str(path), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert "motor 'bend_1_drive': the reference PICO firmware takes a velocity feedback" in err
    assert words in err
    assert not out.exists()


# -- out of scope (behaviours/, safety/): robots the PABs cannot drive, and say otherwise

DRIVE_FEEDBACK = (
    "    feedback:\n      velocity: {raw: [-1200, 1200], per_raw: 0.1 mm/s}\n"
    "      current: {raw: [0, 1023], per_raw: 4 mA}\n"
)


def _why(path: Path, tree: str, network: str, params: dict[str, str]) -> str:
    """Why a run of ``tree`` on the robot of ``path`` ended, or why it was refused."""
    try:
        robot = load_robot(path)
        result = simulate_tree(tree, network=network, params=params, robot=robot)
    except ValidationFailed as exc:
        return str(exc)
    return f"{result.status}: {result.why}"


@pytest.mark.parametrize(
    "feedback", ["", "    feedback:\n      current: {raw: [0, 1023], per_raw: 4 mA}\n"]
)
def test_a_straight_run_on_drives_without_velocity_feedback_says_so(
    tmp_path: Path, feedback: str
) -> None:
    # a drive measures distance by its wheels' speed: with no velocity feedback the
    # straight PAB ran to its 120 s timeout ('drove 0.000 m at 0 mm/s'), or with current
    # alone said 'blocked: every drive draws stall current'; now refused at load
    path = variant(tmp_path, (DRIVE_FEEDBACK, feedback))
    why = _why(path, "straight", "straight", {"distance": "1 m"})
    assert "velocity feedback" in why, why


def test_a_bend_on_a_robot_without_spring_sensors_says_so(tmp_path: Path) -> None:
    # without spring sensors the front half steered into the turn (40 deg, between
    # clamp.unclamped_below and the wall) cannot be told from a clamp closing, so the
    # bend PAB's drive is refused half_transitioning; until 2026-11-30 the refusal did
    # not say why, now it names the bend modules with no spring sensor
    # (check_transitioning in pirate_bt/safety/checks.py)
    edits = [
        (f"      - {{<<: *spring_sensor, slot: 1, name: bend_{k}_spring}}\n", "")
        for k in range(1, 5)
    ]
    path = variant(tmp_path, *edits)
    why = _why(path, "bend", "bend-right", {"roll": "90 deg"})
    assert "spring" in why, why


def test_a_tree_given_as_the_robot_is_named_as_a_tree(capsys: pytest.CaptureFixture[str]) -> None:
    tree = Path(__file__).resolve().parent.parent / "trees" / "bend.yaml"
    code = main(["validate", "--kind", "hardware", str(tree)])
    out = capsys.readouterr().err
    assert code == 2
    assert "not a robot description" in out
    assert "tree" in out.split("not a robot description", 1)[1], out
