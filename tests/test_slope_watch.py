"""A straight whose slope is not as drawn is said, without stopping the mission.

The localiser compares the IMU with the map at turns of 30 degrees or more; a straight
the map draws level that climbs 20 degrees changes nothing it matches on, and the
mission went on without a word (probe 14). :class:`pirate_bt.task.slope_watch.SlopeWatch`
notes it in ``MissionResult.map_notes`` and the report's *Map and pipe* section.
"""

from __future__ import annotations

import math
from pathlib import Path
from types import MappingProxyType
from typing import Any

import pytest
import yaml

import pirate_bt
from pirate_bt.pipes import network_from_data
from pirate_bt.robot.state import RobotState
from pirate_bt.task.report import report_lines
from pirate_bt.task.slope_watch import SlopeWatch


def _write(folder: Path, name: str, segments: list[dict[str, Any]]) -> Path:
    path = folder / f"{name}.yaml"
    data = {"name": name, "diameter": "63 mm", "segments": segments}
    path.write_text(yaml.safe_dump(data), encoding="utf-8")
    return path


def _mission(tmp_path: Path, truth_slope: str | None, map_slope: str | None = None) -> Any:
    level = {"id": "a", "type": "straight", "length": "4 m"}
    drawn = [{**level, "slope": map_slope}] if map_slope else [level]
    _write(tmp_path, "map", drawn)
    route = tmp_path / "r.route"
    route.write_text("network map.yaml\nforward 3 m\n", encoding="utf-8")
    if truth_slope is None:
        return pirate_bt.simulate_mission(route, seed=1)
    truth = _write(
        tmp_path,
        "truth",
        [
            {
                "id": "a",
                "type": "straight",
                "length": "1.5 m",
                **({"slope": map_slope} if map_slope else {}),
            },
            {"id": "s", "type": "straight", "length": "2.5 m", "slope": truth_slope},
        ],
    )
    return pirate_bt.simulate_mission(route, truth=truth, seed=1)


@pytest.mark.parametrize(("truth", "said"), [("20 deg", "20° up"), ("-15 deg", "15° down")])
def test_a_slope_the_map_does_not_draw_is_noted_and_the_mission_goes_on(
    tmp_path: Path, truth: str, said: str
) -> None:
    result = _mission(tmp_path, truth)
    assert result.succeeded, result.why
    assert len(result.map_notes) == 1, result.map_notes
    note = result.map_notes[0]
    assert note.startswith(f"straight 'a': the pipe slopes {said} where the map draws 0°"), note
    report = "\n".join(report_lines(result))
    assert f"- **Not as drawn:** {note}" in report


def test_a_pipe_as_drawn_gives_no_note(tmp_path: Path) -> None:
    assert _mission(tmp_path, None).map_notes == []
    assert _mission(tmp_path, None, map_slope="25 deg").map_notes == []


def test_a_slope_within_the_as_built_bounds_gives_no_note(tmp_path: Path) -> None:
    assert _mission(tmp_path, "6 deg").map_notes == []


def _state(pitch: float) -> RobotState:
    return RobotState(0.0, MappingProxyType({}), imu_rad=MappingProxyType({"pitch": pitch}))


def test_only_a_steady_pitch_over_the_span_driven_is_noted() -> None:
    path = network_from_data(
        {
            "name": "n",
            "diameter": "63 mm",
            "segments": [{"id": "a", "type": "straight", "length": "3 m"}],
        }
    ).main_path()
    watch = SlopeWatch(path, imu_offset_m=0.0)
    for _ in range(200):  # standing: however long, no span is driven
        watch.update(_state(math.radians(20)), 1.0)
    assert watch.notes == []
    for i in range(40):  # a pitch still swinging (a turn the belief has not reached)
        watch.update(_state(math.radians(15 + i)), 1.0 + 0.01 * i)
    assert watch.notes == []
    for i in range(40):  # steady: noted once, however long it lasts
        watch.update(_state(math.radians(20)), 1.5 + 0.01 * i)
    assert len(watch.notes) == 1 and "20° up" in watch.notes[0]
    watch.update(_state(math.radians(20)), 2.0)
    assert len(watch.notes) == 1


def test_the_command_line_and_the_result_dict_say_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from pirate_bt.cli import main

    result = _mission(tmp_path, "20 deg")
    assert result.as_dict()["map_notes"] == result.map_notes
    code = main(["mission", str(tmp_path / "r.route"), "--sim", str(tmp_path / "truth.yaml"), "-q"])
    assert code == 0
    assert "pirate-bt: straight 'a': the pipe slopes 20° up" in capsys.readouterr().err
