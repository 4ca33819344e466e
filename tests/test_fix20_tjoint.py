"""A T-joint turned into on the side the branch does not leave on (fix 20).

The map draws the tee's branch leaving left; the pipe as built has it on the right.
The T-joint PAB steers its front half left and drives in with the rear half holding:
the front slides on over the opening without taking the branch, the rear half's
first joint reaches the opening and swings off the wall, and no half holds the robot.
Before the fix the wheels spun in place for 14 s (a mission: 20 s), the odometry ran
1.1 m (1.6 m) ahead of the robot, and the run failed only when the drive had counted
its 3 m search out: ``no feature (blocked) within 3 m``, or in a mission the
localiser's ``no turn was felt by 3.96 m``. The drive now fails on the slip half a
second after no half holds, and says the branch may leave on another side than steered into.
"""

from __future__ import annotations

import json
from pathlib import Path

import yaml

from pirate_bt import simulate_mission, simulate_tree

REPO = Path(__file__).resolve().parent.parent
TEE = REPO / "scenarios" / "t-joint.yaml"
ROUTE = REPO / "scenarios" / "t-joint.route"


def _branch_right(tmp_path: Path) -> Path:
    """The bundled tee (branch drawn left) as built with its branch on the right."""
    data = yaml.safe_load(TEE.read_text(encoding="utf-8"))
    data["segments"][1]["branch"]["direction"] = "right"
    out = tmp_path / "t-joint-right.yaml"
    out.write_text(yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
    return out


def _odometry_lead_m(trace: Path, node_name: str) -> float:
    """How far the odometry of the drives named ``node_name`` (one per way in the
    T-joint PAB; one runs) was ahead of the simulated robot when the run ended (the
    drive starts at 0 m with the robot at the start)."""
    header, *ticks = (json.loads(line) for line in trace.read_text().splitlines())
    ids = {n["id"] for n in header["tree"]["nodes"] if n["name"] == node_name}
    assert ids
    truth_m = odometry_m = 0.0
    for record in ticks:
        if record.get("type") != "tick":
            continue
        truth_m = record.get("sim", {}).get("distance_m", truth_m)
        for node, said in record.get("feedback", {}).items():
            if node in ids and said.startswith("drove "):
                odometry_m = float(said.split()[1])
    return odometry_m - truth_m


def test_a_turn_into_a_branch_built_on_the_other_side_ends_on_the_slip(
    tmp_path: Path,
) -> None:
    trace = tmp_path / "left.jsonl"
    result = simulate_tree(
        "t-joint", network=_branch_right(tmp_path), params={"direction": "left"}, trace=trace
    )
    assert result.status == "failure" and result.safe_state
    assert result.failing_node is not None and result.failing_node.endswith("front into turn")
    why = result.why
    assert "\n" not in why
    assert why.startswith("no feature (blocked) before slipping: no half holds the robot after")
    assert "rear bend_3 off the wall" in why and "the wheels turn in place" in why
    assert "the tee's branch may leave on another side than steered into" in why
    # the wheels stopped within a second of spinning in place, not after the whole search
    lead = _odometry_lead_m(trace, "front into turn")
    assert 0.0 <= lead < 0.1, lead  # before: 1.12 m ahead


def test_a_mission_whose_map_draws_the_branch_on_the_wrong_side_names_the_tee(
    tmp_path: Path,
) -> None:
    mission = simulate_mission(ROUTE, network=TEE, truth=_branch_right(tmp_path))
    assert mission.status == "failure"
    tee = next(p for p in mission.pabs if p.kind == "t-joint")
    assert tee.outcome == "failure"  # before: 'stopped' by the localiser 31 s in
    assert "before slipping" in tee.why and "may leave on another side" in tee.why
    assert "T-joint 'tee' (left)" in mission.why and "another side" in mission.why
    # the mission's own words: it met an opening, not nothing (as a search that met no
    # turn or opening said before)
    assert "the PAB's search met no turn: the robot slipped over an opening" in mission.why


def test_a_distance_drive_on_a_half_that_lets_go_over_an_opening_fails(tmp_path: Path) -> None:
    # only the rear half clamps; its first joint reaches the tee's opening 2 m on and
    # no half holds: before, the drive counted its 3 m out on spinning wheels and
    # succeeded, the robot 1 m short of where it said it was
    tree = tmp_path / "rear-only.yaml"
    tree.write_text(
        "name: rear-only\n"
        "root:\n"
        "  type: sequence\n"
        "  name: rear only\n"
        "  children:\n"
        "    - {type: clamp, name: clamp rear, half: rear, torque: 0.7 N*m}\n"
        "    - {type: drive, name: on the rear, velocity: 80 mm/s, distance: 3 m}\n",
        encoding="utf-8",
    )
    result = simulate_tree(tree, network=TEE)
    assert result.status == "failure" and result.safe_state
    assert result.why.startswith("slipping: no half holds the robot after")
    assert "front released" in result.why and "over an opening" in result.why
    assert "another side" not in result.why  # nothing here says a branch was turned into
