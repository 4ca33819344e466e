"""Probe 18b: planner code written from docs/api.md, README.md and docs/navigators.md."""

from __future__ import annotations

import json
import pickle
import socket
import threading
from pathlib import Path
from typing import Any

import py_trees
import pytest

import pirate_bt


def test_survey_result_has_what_api_md_says_every_navigation_result_has(
    tmp_path: Path,
) -> None:
    # docs/api.md: NavigationResult (navigations, surveys): the same status, why,
    # failing_node, counters, safe_state, exit_code, summary() and as_dict(); a
    # survey's result had no counters, safe_state or as_dict (AttributeError)
    result = pirate_bt.survey(sim="t-joint", output=tmp_path / "surveyed.yaml")
    assert result.counters is result.navigation.counters
    assert result.safe_state is result.navigation.safe_state
    plain = json.loads(json.dumps(result.as_dict()))
    assert plain["status"] == result.status
    assert plain["why"] == result.why
    assert plain["counters"] == result.counters.as_dict()
    assert plain["survey"]["counts"] == result.counts()
    assert plain["survey"]["output"] == str(tmp_path / "surveyed.yaml")
    assert plain["survey"]["unexplored"] == result.unexplored
    segments = plain["survey"]["network"]["segments"]
    assert [s["type"] for s in segments].count("tee") == result.counts()["tee"] == 1


def test_a_second_run_on_a_busy_connection_is_refused_not_interleaved() -> None:
    # two threads ran trees on one connection at once: both ticked the same robot,
    # each failed on the other's motor conflict and the robot was left in its safe
    # state; the second is refused now, and the first runs as if alone
    seen: list[str] = []

    with pirate_bt.connect("sim:straight") as robot:

        def second() -> None:
            try:
                robot.run("straight", params={"distance": "0.2 m"})
                seen.append("ran")
            except pirate_bt.InputError as exc:
                seen.append(str(exc))

        def observe(runner: object, connection: object) -> None:
            thread = threading.Thread(target=second)
            thread.start()
            thread.join()

        first = robot.run("straight", params={"distance": "0.3 m"}, observe=observe)
        assert seen == [
            "connection: simulator: straight is running a tree already; run one tree at"
            " a time on a connection"
        ]
        assert first.status == "success", first.why
        assert robot.counters().safe_states == 0
        again = robot.run("straight", params={"distance": "0.1 m"})
        assert again.status == "success", again.why


def _refused_port() -> str:
    with socket.socket() as s:  # a port nobody listens on
        s.bind(("127.0.0.1", 0))
        return f"socket://127.0.0.1:{s.getsockname()[1]}"


def test_a_mission_refused_at_connect_leaves_no_empty_output_folder(tmp_path: Path) -> None:
    # run_mission(..., output="out/run1") on a port that did not answer raised its
    # LinkError and left out/run1 made and empty
    with pytest.raises(pirate_bt.LinkError):
        pirate_bt.run_mission(
            "scenarios/bend-right.route", port=_refused_port(), output=tmp_path / "out" / "run1"
        )
    assert list(tmp_path.iterdir()) == []


def test_a_mission_refused_for_its_live_view_leaves_no_empty_trace_folder(
    tmp_path: Path,
) -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        with pytest.raises(pirate_bt.InputError, match="the port is taken"):
            pirate_bt.simulate_mission(
                "scenarios/bend-right.route",
                foxglove=f"127.0.0.1:{taken.getsockname()[1]}",
                trace=tmp_path / "runs" / "a" / "trace.jsonl",
            )
    assert list(tmp_path.iterdir()) == []


def test_a_navigation_refused_at_connect_leaves_no_folder_on_its_trace_way(
    tmp_path: Path,
) -> None:
    # the trace folder itself was taken away again, the folder made above it was not
    class Once:
        def next_step(self, obs: pirate_bt.Observation) -> pirate_bt.Step | None:
            return None

    with pytest.raises(pirate_bt.InputError, match="faults"):
        pirate_bt.navigate(
            Once(),
            sim="straight",
            faults="motor_stall:no_such_drive@1s",
            trace=tmp_path / "a" / "b",
        )
    with pytest.raises(pirate_bt.LinkError):
        pirate_bt.navigate(Once(), port=_refused_port(), trace=tmp_path / "c" / "d")
    assert list(tmp_path.iterdir()) == []


def test_a_survey_that_writes_no_file_leaves_no_folder_made_for_it(tmp_path: Path) -> None:
    # "nothing was surveyed: no file is written", and out/a was left made and empty
    result = pirate_bt.survey(
        sim="straight",
        output=tmp_path / "out" / "a" / "surveyed.yaml",
        faults="motor_stall:bend_3_drive@0s+1000s",
    )
    assert result.status == "failure"
    assert result.why.endswith("nothing was surveyed: no file is written")
    assert result.output is None
    assert list(tmp_path.iterdir()) == []


class _TwoArgumentError(Exception):
    """An exception of a common shape: pickled, it cannot be read back."""

    def __init__(self, code: int, message: str) -> None:
        super().__init__(message)
        self.code = code


def test_a_run_whose_node_raised_an_unpicklable_exception_still_pickles() -> None:
    # a process pool running robot.run(...) in its workers broke (BrokenProcessPool)
    # when a planner's node raised such an exception: the result could not be read back
    from pirate_bt.behaviours.base import Leaf, NodeParams

    class Boom(Leaf):
        Params = NodeParams

        def update(self) -> py_trees.common.Status:
            raise _TwoArgumentError(7, "sensor said no")

    with pirate_bt.connect("sim:straight") as robot:
        result = robot.run(Boom.build("boom", robot.context()), max_time="2 s")
    assert isinstance(result.error, _TwoArgumentError)  # the caller's own, as raised
    back = pickle.loads(pickle.dumps(result))
    assert (back.status, back.why, back.failing_node) == (
        "failure",
        "_TwoArgumentError in boom: sensor said no",
        "boom",
    )
    # the stand-in's text; or, where tblib's pickling support is installed (importing
    # Dask's distributed does so for the whole process), the error itself read back
    assert str(back.error) in ("_TwoArgumentError: sensor said no", "sensor said no")
    assert back.loop is not None and back.loop.error is back.error
    assert back.exit_code == result.exit_code == 1
    assert back.as_dict() == result.as_dict()


def _simulated(record: dict[str, Any]) -> dict[str, Any]:
    """A result's record without what the wall clock decides: its wall time, and its
    overruns (ticks over their wall-clock budget: one in a suite on a heavily loaded
    machine, none on a quiet one)."""
    counters = {k: v for k, v in record["counters"].items() if k != "overruns"}
    return record | {"wall_s": 0, "counters": counters}


def test_numpy_numbers_are_numbers_to_the_api() -> None:
    # seed=numpy.int64(3) was refused: "give a whole number ..., not np.int64(3)";
    # rate=numpy.float32(25) "give text with a unit or a number in SI units, not a
    # float32"; navigate's max_steps and survey's search likewise
    np = pytest.importorskip("numpy")
    plain = pirate_bt.simulate_tree("straight", params={"distance": 0.2}, seed=3, rate=25)
    result = pirate_bt.simulate_tree(
        "straight",
        params={"distance": 0.2},
        seed=np.int64(3),
        rate=np.float32(25),
        max_time=np.int32(60),
    )
    assert _simulated(result.as_dict()) == _simulated(plain.as_dict())
    json.dumps(result.as_dict())

    class Twice:
        def next_step(self, obs: pirate_bt.Observation) -> pirate_bt.Step | None:
            return pirate_bt.Step("straight", distance="0.2 m") if obs.step < 2 else None

    navigation = pirate_bt.navigate(
        Twice(), sim="straight", max_steps=np.int64(5), seed=np.uint8(1)
    )
    assert (navigation.status, navigation.steps) == ("success", 2)
    survey = pirate_bt.survey(sim="straight", search=np.float32(2.0))
    assert survey.status == "success", survey.why
    with pytest.raises(pirate_bt.InputError, match=r"seed: give a whole number"):
        pirate_bt.simulate_tree("straight", params={"distance": 0.2}, seed=np.bool_(True))


def test_numpy_numbers_are_si_numbers_as_tree_parameters() -> None:
    # params={"distance": numpy.float32(0.25)} was refused "parameter 'distance':
    # expected a length quantity such as '1 m'", where 0.25 is a quarter metre
    np = pytest.importorskip("numpy")
    plain = pirate_bt.simulate_tree("straight", params={"distance": 0.25})
    result = pirate_bt.simulate_tree("straight", params={"distance": np.float32(0.25)})
    assert _simulated(result.as_dict()) == _simulated(plain.as_dict())
    loaded = pirate_bt.load_tree("bend", params={"roll": np.int64(0)})
    assert loaded.params["roll"] == pirate_bt.load_tree("bend", params={"roll": 0}).params["roll"]


def test_connect_takes_a_network_spec_as_simulate_tree_and_navigate_do() -> None:
    # missions.md builds as-built variants as NetworkSpecs (perturb_network); connect()
    # refused one, "cannot connect to a NetworkSpec", where simulate_tree's network=,
    # simulate_mission's truth= and navigate's sim= take it
    spec = pirate_bt.load_network("bend-right").spec
    with pirate_bt.connect(spec) as robot:
        assert robot.description == "simulator: bend-right"
        result = robot.run("straight", params={"distance": "0.2 m"})
    with pirate_bt.connect("sim:bend-right") as robot:
        named = robot.run("straight", params={"distance": "0.2 m"})
    assert result.status == "success", result.why
    assert (result.ticks, result.sim_time_s) == (named.ticks, named.sim_time_s)


class _Straights:
    def __init__(self, steps: int) -> None:
        self.steps = steps

    def next_step(self, obs: pirate_bt.Observation) -> pirate_bt.Step | None:
        return pirate_bt.Step("straight", distance="0.1 m") if obs.step < self.steps else None


def test_a_navigation_into_an_earlier_ones_trace_folder_leaves_only_its_own_steps(
    tmp_path: Path,
) -> None:
    # 2 steps into the folder of a navigation of 3 left step-003.jsonl beside the new
    # navigation.jsonl, a step the new one never ran
    folder = tmp_path / "trace"
    pirate_bt.navigate(_Straights(3), sim="straight", trace=folder)
    (folder / "notes.txt").write_text("mine")
    result = pirate_bt.navigate(_Straights(2), sim="straight", trace=folder)
    assert result.steps == 2
    names = sorted(p.name for p in folder.iterdir())
    assert names == ["navigation.jsonl", "notes.txt", "step-001.jsonl", "step-002.jsonl"]
    assert pirate_bt.read_trace(folder / "step-002.jsonl").outcome == "success"


def test_a_tree_built_on_one_connection_is_refused_on_another() -> None:
    # a root built once with robot.context() and run on the next connection commanded
    # the first one's robot: closed, the run failed "link_down: the link to the robot is
    # not connected"; open, this robot never moved and the run ran out its time limit
    from pirate_bt.behaviours.primitives import Clamp

    with pirate_bt.connect("sim:straight") as first, pirate_bt.connect("sim:straight") as second:
        root = py_trees.composites.Sequence("mine", memory=True)
        root.add_child(Clamp.build("clamp", first.context(), half="rear", torque="0.7 N*m"))
        with pytest.raises(pirate_bt.InputError) as refused:
            second.run(root)
        assert str(refused.value) == (
            "tree: 'mine/clamp' was built with another connection's context(); build it with"
            " this connection's (simulator: straight): its commands would go to the other robot"
        )
        with pytest.raises(pirate_bt.InputError, match="another connection's context"):
            second.runner(root)
        assert second.counters().safe_states == 0
        assert first.run(root).status == "success"


def test_simulate_tree_refuses_a_tree_built_on_a_connection() -> None:
    # it ran out its time limit, "s/c was still running", its clamp commanding the
    # connection's robot while the simulator it started stood still
    from pirate_bt.behaviours.primitives import Clamp

    with pirate_bt.connect("sim:straight") as robot:
        root = Clamp.build("clamp", robot.context(), half="rear", torque="0.7 N*m")
        with pytest.raises(pirate_bt.InputError, match="'clamp' was built with another"):
            pirate_bt.simulate_tree(root, max_time="5 s")


def test_a_mission_result_and_a_campaign_result_pickle() -> None:
    # a MissionResult held the py_trees tree ("cannot pickle 'generator' object"), and a
    # CampaignResult its counts as a MappingProxyType: neither came back from a pool
    import pickle

    import pirate_bt

    mission = pirate_bt.simulate_mission("straight")
    back = pickle.loads(pickle.dumps(mission))
    assert back.status == mission.status and back.why == mission.why
    assert [p.outcome for p in back.pabs] == [p.outcome for p in mission.pabs]
    assert back.tree is None
    spec = {
        "name": "p",
        "runs": [{"tree": "straight", "params": {"distance": "0.1 m"}}],
        "seeds": {"count": 1},
    }
    campaign = pirate_bt.run_campaign(spec)
    again = pickle.loads(pickle.dumps(campaign))
    assert dict(again.counts) == dict(campaign.counts) and again.counts["success"] == 1
    with pytest.raises(TypeError):
        again.counts["success"] = 2  # type: ignore[index]


def test_a_step_takes_numpy_numbers_as_si_numbers() -> None:
    import numpy as np

    from pirate_bt.task.navigation import Step, _quantity

    assert _quantity(Step("straight", distance=np.float32(0.25)), "distance", "length", "1 m") == (
        pytest.approx(0.25)
    )


def test_mission_and_navigation_results_with_an_unpicklable_error_still_pickle() -> None:
    # a MissionResult or NavigationResult whose error was such an exception broke a
    # process pool (BrokenProcessPool), as a RunResult's did before the stand-in
    import dataclasses

    from pirate_bt.task.navigate_result import NavigationResult

    mission = pirate_bt.simulate_mission(
        Path(__file__).resolve().parents[1] / "scenarios" / "straight.route"
    )
    raised = _TwoArgumentError(7, "sensor said no")
    mission = dataclasses.replace(mission, run=dataclasses.replace(mission.run, error=raised))
    navigation = NavigationResult(navigator="mine", status="failure", why="w", error=raised)
    for result in (mission, navigation):
        back = pickle.loads(pickle.dumps(result))
        assert str(back.error) in ("_TwoArgumentError: sensor said no", "sensor said no")
        assert back.status == result.status
