"""What a planner writing scripts from the manual alone ran into (probe 12).

Each test is a short run on the simulator, as a script from the manual would make it.
"""

from __future__ import annotations

from pathlib import Path

import pirate_bt
from pirate_bt import Observation, Step


class _Metre:
    """One straight metre, then done."""

    def next_step(self, obs: Observation) -> Step | None:
        return Step("straight", distance="0.3 m") if obs.step < 1 else None


def test_a_survey_result_has_status_and_failing_node_as_every_result(tmp_path: Path) -> None:
    # a planner reads result.status on every result; SurveyResult raised AttributeError
    done = pirate_bt.survey(sim="straight", output=tmp_path / "s.yaml")
    assert done.status == "success" == done.navigation.status
    assert done.failing_node is None
    stopped = pirate_bt.survey(
        sim="straight", output=tmp_path / "t.yaml", faults="motor_stall:bend_1_drive@3s+60s"
    )
    assert stopped.status == "failure"
    assert stopped.why.startswith("stall: bend_1_drive")
    assert stopped.failing_node == stopped.navigation.failing_node
    assert stopped.failing_node is not None and "drive straight" in stopped.failing_node


def test_summaries_count_one_step_and_one_pab_in_the_singular() -> None:
    # was "(1 steps, 1 PABs, ...)"
    result = pirate_bt.navigate(_Metre(), sim="straight")
    assert result.steps == 1 and len(result.pabs) == 1
    assert "(1 step, 1 PAB, " in result.summary()


def test_simulate_tree_takes_a_network_spec_as_simulate_mission_does() -> None:
    # perturb_network returns a NetworkSpec: simulate_mission(truth=...), navigate(sim=...)
    # and survey(sim=...) took it, simulate_tree refused it (ArgumentTypeError)
    from pirate_bt.pipes.asbuilt import perturb_network

    spec = perturb_network(pirate_bt.load_network("straight").spec, seed=2)
    result = pirate_bt.simulate_tree("straight", network=spec, params={"distance": "0.2 m"})
    assert result.status == "success"
    assert result.target == f"simulator: {spec.name}"


def test_a_mission_stopped_by_the_supervisor_names_its_pab_by_path() -> None:
    # a board reset stops a mission on stale data: failing_node was the PAB's bare label
    # ('03 T-joint left (tee) (line 5)'), where a stall or a disagreement gives the path
    mission = pirate_bt.simulate_mission("t-joint", faults="board_reset:22@30s")
    assert mission.why.startswith("stale data: bend_1_angle")
    assert mission.failing_node == "mission/route/03 T-joint left (tee) (line 5)"
    assert mission.failed_pab is not None
    assert mission.failing_node.endswith("/" + mission.failed_pab.label)


def test_a_mission_of_one_pab_says_it_in_the_singular(tmp_path: Path) -> None:
    # was "mission completed: 1 PABs, ..."
    route = tmp_path / "one.route"
    route.write_text("network straight\nforward 0.3 m\n", encoding="utf-8")
    result = pirate_bt.simulate_mission(route)
    assert result.why.startswith("mission completed: 1 PAB, "), result.why
