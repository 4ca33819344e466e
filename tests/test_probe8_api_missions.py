"""The eighth probe of the planner's API: missions whose outputs cannot be written.

Each test is a bug the probe found; it failed before its fix.
"""

from __future__ import annotations

import functools
from pathlib import Path

import pytest

import pirate_bt
from pirate_bt.errors import InputError
from tests.hostile_support import refused


@pytest.mark.parametrize(
    ("option", "value", "words"),
    [
        # each raised a bare FileNotFoundError / PermissionError once the run had started
        # (the supervisor's safe state: "planner code raised FileNotFoundError")
        ("output", "/proc/pirate-bt-probe", "output: cannot write in the folder /proc/"),
        ("trace", "/proc/pirate-bt-probe/t.jsonl", "trace: cannot write in the folder /proc/"),
    ],
)
def test_a_mission_output_that_cannot_be_written_is_bad_input_before_it_connects(
    option: str, value: str, words: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    import pirate_bt.api.missions as missions

    def no_connection(*_args: object, **_kwargs: object) -> None:
        raise AssertionError("connected before the output was checked")

    monkeypatch.setattr(missions, "connect", no_connection)
    text = refused(lambda: pirate_bt.simulate_mission("bend-right", **{option: value}), words)
    assert "No such file or directory" in text
    with pytest.raises(InputError):
        pirate_bt.run_mission("bend-right", port="socket://127.0.0.1:1", **{option: value})


def test_a_navigation_trace_or_survey_output_that_cannot_be_written_is_bad_input(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # both raised a bare FileNotFoundError: [Errno 2] No such file or directory: '/proc/x'
    import pirate_bt.api.navigation as navigation

    def no_connection(*_args: object, **_kwargs: object) -> None:
        raise AssertionError("connected before the output was checked")

    monkeypatch.setattr(navigation, "connect", no_connection)
    refused(
        lambda: pirate_bt.navigate(
            "goal", sim="lab", map="lab", params={"segment": "riser"}, trace="/proc/p8/t"
        ),
        "trace: cannot write in the folder /proc/p8",
    )
    refused(
        lambda: pirate_bt.survey(sim="t-joint", output="/proc/p8/s.yaml"),
        "output: cannot write in the folder /proc/p8",
    )


def test_a_run_held_by_an_operator_all_along_says_so() -> None:
    # was: "time limit of 5 s reached after 101 ticks", nothing of why no node ran
    tree = pirate_bt.load_tree("straight", params={"distance": "0.1 m"})
    with pirate_bt.connect("sim:straight", mode="manual") as robot:
        result = robot.run(tree, max_time="2 s")
    assert result.status == "failure" and result.why.startswith("time limit of 2 s reached")
    assert "the tree was paused for 40 of its ticks while an operator held the robot" in result.why
    assert result.why.endswith("(manual mode)") and "\n" not in result.why


@pytest.mark.parametrize(
    ("options", "words"),
    [
        # a TypeError from inside the report, after the folder had been made
        ({"extra_sections": 5}, "extra_sections: give a list of (heading, [lines]) pairs"),
        ({"extra_sections": [("h", "not a list")]}, "extra_sections: each item is a"),
        ({"extra_pictures": [("caption",)]}, "extra_pictures: each item is a"),
        # written into the report as it was
        ({"wall_s": float("nan")}, "wall_s: nan is not a finite number of seconds"),
        ({"warn": 3}, "warn: give a function"),
    ],
)
def test_write_mission_outputs_checks_its_arguments_before_writing(
    tmp_path: Path, options: dict[str, object], words: str
) -> None:
    mission = _short_mission()
    out = tmp_path / "out"
    refused(lambda: pirate_bt.write_mission_outputs(mission, out, **options), words)  # type: ignore[arg-type]
    assert not out.exists()


@functools.cache
def _short_mission() -> pirate_bt.MissionResult:
    return pirate_bt.simulate_mission("bend-right", max_time="2 s")


def test_a_survey_never_writes_its_network_over_a_file_that_is_not_yaml(tmp_path: Path) -> None:
    # survey(output="planner.py") drove the survey and wrote the network's YAML over it
    planner = tmp_path / "planner.py"
    planner.write_text("print('my planner')\n", encoding="utf-8")
    refused(
        lambda: pirate_bt.survey(sim="t-joint", output=planner),
        "output: ",
        "is not a .yaml file name",
    )
    assert planner.read_text(encoding="utf-8") == "print('my planner')\n"
