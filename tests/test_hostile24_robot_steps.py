"""A drive's velocity step so coarse that the nominal speed is sent as raw 0.

``per_raw: 1e306 mm/s`` on the drives' velocity mode validated, and every run drove
0 m until its timeout (*drove 0.000 m at 0 mm/s*, two minutes later): the nominal
80 mm/s is 8e-305 raw steps, sent as 0. ``validate`` now refuses it at the
``per_raw``, as it refuses a robot no run could drive.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.cli import main

_ROBOT = (Path(__file__).resolve().parents[1] / "hardware" / "pirate.yaml").read_text(
    encoding="utf-8"
)
_DRIVE = "      velocity: {raw: [-1200, 1200], per_raw: 0.1 mm/s}\n    limits:"


@pytest.mark.parametrize("per_raw", ["1e306 mm/s", "1000 m/s", "-200 mm/s"])
def test_a_step_coarser_than_twice_the_nominal_speed_is_refused_at_per_raw(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], per_raw: str
) -> None:
    assert _DRIVE in _ROBOT
    path = tmp_path / "robot.yaml"
    path.write_text(_ROBOT.replace(_DRIVE, _DRIVE.replace("0.1 mm/s", per_raw), 1))
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr().err
    line = _ROBOT[: _ROBOT.index(_DRIVE)].count("\n") + 1  # the drive template's velocity
    assert err.startswith(f"{path}:{line}:")
    assert err.count("\n") == 1
    assert "drive 'bend_1_drive': one raw step of its velocity mode is" in err
    assert "nominal_speed 80 mm/s is sent as no speed at all" in err


def test_a_step_just_fine_enough_still_validates(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "robot.yaml"
    # 80 mm/s is 0.53 raw steps of 150 mm/s: sent as 1, the drive moves
    path.write_text(_ROBOT.replace(_DRIVE, _DRIVE.replace("0.1 mm/s", "150 mm/s"), 1))
    code = main(["validate", str(path)])
    err = capsys.readouterr().err
    assert code == 0, err
