"""Robot descriptions whose numbers contradict each other are refused at the key to change.

Before, each of these validated and the simulator ran it: a wall-contact table whose
angle went back and forth with the diameter (a joint's angle at the wall named two
pipes), an ``unclamped_below`` past the first wall contact, a free drive current above
the stalled one, a position-mode hold torque past what the joints may press with.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.cli import main
from pirate_bt.robot import load_robot

GOOD = (Path(__file__).resolve().parent.parent / "hardware" / "pirate.yaml").read_text()


def variant(tmp_path: Path, old: str, new: str) -> Path:
    assert GOOD.count(old) == 1, old
    path = tmp_path / "my-robot.yaml"
    path.write_text(GOOD.replace(old, new), encoding="utf-8")
    return path


@pytest.mark.parametrize(
    ("old", "new", "words"),
    [
        (
            "- {diameter: 100 mm, angle: 1.69 rad}",
            "- {diameter: 100 mm, angle: 1.50 rad}",
            "the wall-contact angle 85.94 deg of a 100 mm pipe does not go on the way the"
            " angles before it go (74.48, 83.08, 90.53, 85.94 deg)",
        ),
        (
            "- {diameter: 80 mm, angle: 1.58 rad}",
            "- {diameter: 80 mm, angle: 1.45 rad}",
            "the wall-contact angle 83.08 deg of a 80 mm pipe does not go on",
        ),
        # every tree with a bend was refused: "bend: angle: 40.0° steers less than the
        # robot's motion.steer_angle (200.0°) ... (give the tree's steer parameter at
        # least that)", which no joint stopping at 110 deg could be given
        (
            "steer_angle: 30 deg",
            "steer_angle: 200 deg",
            "bend joint 'bend_1_joint' stops at 110 deg (limits.angle), short of 201.7 deg"
            " (motion.steer_angle + safety.angle_tolerance)",
        ),
        (
            "unclamped_below: 0.35 rad",
            "unclamped_below: 1.5 rad",
            "unclamped_below 85.94 deg is not below the smallest wall-contact angle 74.48 deg",
        ),
        (
            "drive_free_current: 0.15 A",
            "drive_free_current: 2 A",
            "drive_free_current 2 A is not less than drive_stall_current 1.5 A",
        ),
        (
            "position_hold_torque: 0.4 N*m",
            "position_hold_torque: 40 N*m",
            "position_hold_torque 40 N*m is more than 'front_tilt' may press with (0.5 N*m,"
            " its torque mode and limit)",
        ),
    ],
)
def test_numbers_that_contradict_each_other_are_refused_at_their_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], old: str, new: str, words: str
) -> None:
    path = variant(tmp_path, old, new)
    code = main(["validate", str(path)])
    lines = capsys.readouterr().err.splitlines()
    assert code == 2
    assert len(lines) == 1, lines
    line = next(i for i, text in enumerate(path.read_text().splitlines(), 1) if new in text)
    assert lines[0].startswith(f"{path}:{line}:"), lines
    assert words in lines[0], lines


def test_a_wall_contact_table_falling_throughout_still_validates(tmp_path: Path) -> None:
    angles = ["1.30", "1.45", "1.58", "1.69", "1.78"]
    text = GOOD
    for a, b in zip(angles, reversed(angles), strict=True):
        text = text.replace(f"angle: {a} rad}}", f"angle: X{b} rad}}")
    path = tmp_path / "falling.yaml"
    path.write_text(text.replace("angle: X", "angle: "), encoding="utf-8")
    robot = load_robot(path)
    assert [round(p.angle, 2) for p in robot.clamp.contact_angles] == [1.78, 1.69, 1.58, 1.45, 1.3]
