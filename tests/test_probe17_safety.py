"""Probe 17 of the protective layer and the behaviours: a robot description's limits,
guards and the supervisor used from Python as the docs describe them, on the simulator.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import py_trees
import pytest

import pirate_bt
from pirate_bt.behaviours.guards import is_clamped, skip_if, state_fresh, while_
from pirate_bt.cli import main
from pirate_bt.errors import ValidationFailed

ROOT = Path(__file__).resolve().parent.parent
CLIP = "acceleration: {max: 400 mm/s^2, policy: clip}"


def _refusing_robot(tmp_path: Path) -> Path:
    """The bundled robot, its drives' acceleration limit refused rather than clipped."""
    text = (ROOT / "hardware" / "pirate.yaml").read_text("utf-8")
    assert CLIP in text
    path = tmp_path / "refuse.yaml"
    path.write_text(text.replace(CLIP, CLIP.replace("clip", "refuse")), encoding="utf-8")
    return path


# -- 1. limits with policy refuse ------------------------------------------------------


def test_a_drive_steps_within_an_acceleration_limit_that_refuses(tmp_path: Path) -> None:
    # A user who asks the supervisor to refuse over-acceleration (docs/safety.md, each
    # limit's policy) could run no PAB at all: every drive asked for its full speed at
    # once and was refused (*acceleration_limit: bend_1_drive: velocity change from 0 in
    # 0.1 s: target 0.08 outside [-0.04, 0.04]*), until 2026-11-30. The drive now steps
    # toward its speed by what the limit allows, as the clip policy did for it.
    robot = _refusing_robot(tmp_path)
    result = pirate_bt.simulate_tree("straight", params={"distance": "0.3 m"}, robot=robot)
    assert result.status == "success", result.why


# -- 3. a halted joint -----------------------------------------------------------------


def test_the_safe_state_brakes_a_rotation_on_its_way() -> None:
    # Every stop, the supervisor's safe state included, brakes the rotation at once
    # (docs/safety.md, *Stop category*). The safe state stopped the drives only: a
    # rotate stopped by its timeout left its last rate-limited setpoint, and the halves
    # went on turning 6° after the failed run had handed the robot back (18° to 24°),
    # until 2026-11-30.
    tree = {
        "name": "p",
        "root": {
            "type": "sequence",
            "children": [
                {"type": "clamp", "name": "clamp rear", "half": "rear", "torque": "0.7 N*m"},
                {
                    "type": "timeout",
                    "duration": "0.3 s",
                    "child": {"type": "rotate", "name": "rot", "angle": "90 deg"},
                },
            ],
        },
    }
    with pirate_bt.connect("straight") as robot:
        result = robot.run(tree, max_time="30 s")
        assert result.status == "failure", result.why
        sim = robot.simulator
        sup = robot.supervisor
        at_end = sim.truth().rotation_rad
        assert at_end > math.radians(5)  # it was turning
        for _ in range(20):
            sup.clock.sleep(0.05)
            sup.tick()
        assert abs(sim.truth().rotation_rad - at_end) < math.radians(0.5)


# -- guards ----------------------------------------------------------------------------


def test_a_guard_on_the_robot_s_state_gets_a_robot(tmp_path: Path) -> None:
    # A tree whose only robot node was a guard's state comparison ran with no robot
    # (`pirate-bt run tree.yaml --sim straight` said *no robot*), and the guard failed
    # with *no robot attached* although the user had asked for the simulator, until
    # 2026-11-30.
    tree = {
        "name": "g",
        "root": {
            "type": "skip_if",
            "condition": {"state": "imu.pitch", "op": ">", "value": "10 deg"},
            "child": {"type": "success"},
        },
    }
    result = pirate_bt.simulate_tree(tree)
    assert result.status == "success", result.why


@pytest.mark.parametrize(
    ("node", "said"),
    [
        (
            "{type: skip_if, condition: {state: joint_angle.bend_9, op: '>', value: 10 deg},"
            " child: {type: success}}",
            "'bend_9' is none of the robot's bend modules with an angle sensor (bend_1,",
        ),
        (
            "{type: while, condition: [{state: motor_current.rotate, op: '>', value: 1 A}],"
            " child: {type: success}}",
            "'rotate' is none of the robot's motors that report a current",
        ),
        ("{type: state_fresh, channels: [imu.pich]}", "did you mean 'imu.pitch'?"),
    ],
)
def test_a_guard_naming_what_the_robot_has_not_is_refused_at_load(
    node: str, said: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # It loaded and validated clean, then failed when ticked with a message that blamed
    # the readings (*joint_angle.bend_9 has no reading*, *stale: imu.pich*), until
    # 2026-11-30.
    path = tmp_path / "g.yaml"
    path.write_text(f"name: g\nroot: {node}\n", encoding="utf-8")
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"{path}:2:"), err
    assert said in err and "\n" not in err, err


def test_a_rotate_halted_by_a_parallel_holds_where_it_is() -> None:
    # A rotate halted by its parallel (another branch succeeded first; no stop, no
    # safe state) left its last rate-limited setpoint: the halves turned 3° more after
    # the run had succeeded, and a hold at the reading was clipped back to that
    # setpoint by the rate limit (docs/safety.md, *Known limits*), until 2026-11-30.
    # The rate limit lets a setpoint back toward the joint's reading pass (the joint
    # slows down), and a halted rotate holds the rotation where it reads.
    tree = {
        "name": "p",
        "root": {
            "type": "sequence",
            "children": [
                {"type": "clamp", "name": "clamp rear", "half": "rear", "torque": "0.7 N*m"},
                {
                    "type": "parallel",
                    "policy": "one",
                    "children": [
                        {"type": "rotate", "name": "rot", "angle": "90 deg"},
                        {"type": "wait", "duration": "0.3 s"},
                    ],
                },
            ],
        },
    }
    with pirate_bt.connect("straight") as robot:
        result = robot.run(tree, max_time="30 s")
        assert result.status == "success", result.why
        sim = robot.simulator
        sup = robot.supervisor
        at_end = sim.truth().rotation_rad
        assert at_end > math.radians(5)  # it was turning
        for _ in range(20):
            sup.clock.sleep(0.05)
            sup.tick()
        assert abs(sim.truth().rotation_rad - at_end) < math.radians(1)


@pytest.mark.parametrize(
    "build",
    [
        lambda child: skip_if(child, "imu.pitch > 10 deg"),
        lambda child: while_(child, None),
        lambda child: skip_if(child, {"state": "imu.pitch", "op": ">", "value": "abc"}),
        lambda child: is_clamped(None, "middle"),  # type: ignore[arg-type]
        lambda child: state_fresh(None, "imu.pitch"),  # type: ignore[arg-type]
    ],
)
def test_a_guard_built_in_python_with_bad_parameters_is_one_located_line(build: Any) -> None:
    # The guards' Python builders raised pydantic's many-line ValidationError, a
    # TypeError for condition=None, and took a text condition for a list of its
    # letters, until 2026-11-30; they check their parameters as `Cls.build` does
    # (docs/trees.md): one ValidationFailed at the caller's line.
    child = py_trees.behaviours.Success(name="c")
    with pytest.raises(ValidationFailed) as info:
        build(child)
    text = str(info.value)
    assert text.split(":")[0].endswith("test_probe17_safety.py") and "\n" not in text, text
