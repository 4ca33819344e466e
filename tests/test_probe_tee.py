"""The probe-tee PAB end to end: which side a tee's branch leaves on, found with no map.

Each case runs what the ``explore`` navigator runs at a tee, in one simulated session
(runner -> supervisor -> link -> simulator, typical sensor noise, some with link
faults): a straight drive with ``stop_at_feature`` that stops with the front half over
the opening, then ``trees/probe-tee.yaml``; the side it writes to ``probe_side`` must be
the network's. From where it leaves the robot the T-joint PAB must then pass the tee
both ways, each in a run of its own (the same seed replays the same session): into the
branch found (``t-joint.yaml`` left or right; up and down, which ``t-joint.yaml`` does
not take, through ``lib/turn.yaml`` with that roll, as it would) and straight on. A case
passes on the simulator's truth: every PAB succeeded, no violation, no damage, no slip,
no command refused, both halves clamped, the tee undecided and the front tip before the
middle of the opening after the probe (the start of the branch's turn), every module
in the branch (or past the tee) after the T-joint PAB. The variants are written into a
temporary directory from the bundled ``scenarios/t-joint.yaml`` (63 mm, branch left).

Straight on is run after the probe in a 51 mm tee too: ``tee-straight.yaml`` counts its
released front half's 160 mm across from the opening's near edge (where bend I began to
swing off the wall), not from where the search stopped, 30 mm later in a 51 mm pipe.
Before 2026-11-29 that put bend III at the opening's edge with the front half not yet
clamped (a slip) whenever it started less than about 0.3 m before the opening.
"""

from __future__ import annotations

import logging
from collections.abc import Iterator
from pathlib import Path

import py_trees
import pytest
from test_pabs_backwards import (
    TREES,
    Run,
    Session,
    clean,
    first_feature,
    tee_network,
)

from pirate_bt.pipes import Network, PieceKind
from pirate_bt.resources import data_dir
from pirate_bt.robot import Half, load_robot
from pirate_bt.robot.description import Role

ROBOT = load_robot()
SCENARIOS = data_dir("scenarios")
LINK_FAULTS = "drop=0.05,corrupt=0.01"
START_M = 1.5
"""Where the straight drive starts (the tee's opening is about 0.55 m on)."""
ROLL = {"left": "-90 deg", "right": "90 deg", "up": "0 deg", "down": "180 deg"}
BEND_1_M = next(
    sum(x.length for x in ROBOT.modules[:i]) + m.length / 2
    for i, m in enumerate(ROBOT.modules)
    if m.role is Role.BEND
)
"""Bend I's centre behind the front tip (0.1225 m): the first joint over an opening."""

# Where probe-tee leaves the front tip, before the middle of the opening (measured in
# docs/pabs.md: 0.058 to 0.071 m over 51 to 63 mm tees and up to four probes).
END_BEFORE_MIDDLE_M = (0.05, 0.08)


@pytest.fixture(autouse=True)
def quiet(caplog: pytest.LogCaptureFixture) -> Iterator[None]:
    caplog.set_level(logging.ERROR)
    py_trees.blackboard.Blackboard.clear()
    yield


def network(tmp: Path, side: str, diameter: str) -> Path:
    if (side, diameter) == ("left", "63 mm"):
        return SCENARIOS / "t-joint.yaml"
    return tee_network(tmp, side, diameter)


def probed(net: Path, seed: int, faults: str | None) -> tuple[Session, Run, Run, str | None, float]:
    """A session driven to the opening and probed: (session, straight, probe, side,
    the opening's middle)."""
    session = Session(net, start_m=START_M, seed=seed, link_faults=faults)
    opening = first_feature(session.network, PieceKind.TEE).opening_m
    assert opening is not None
    to_tee = session.run("straight.yaml", {"distance": "3 m", "stop_at_feature": "true"})
    probe = session.run("probe-tee.yaml", {})
    side = py_trees.blackboard.Blackboard.storage.get("/probe_side")
    return session, to_tee, probe, side, opening


def probe_problems(
    network: Network, to_tee: Run, probe: Run, opening: float, stuck: list[str]
) -> list[str]:
    # the straight stopped with bend I over the opening (drive front_opening): the
    # front half, asked to clamp, finds no wall there
    problems = [
        f"straight: {p}"
        for p in clean(to_tee, refusals=False)
        if p != "not both halves clamped at the end"
    ]
    bend_1 = to_tee.truth.front_m - BEND_1_M
    if not network.path({}).piece_at(bend_1).over_opening(bend_1):
        problems.append(f"the straight stopped with bend I at {bend_1:.3f} m, not over the opening")
    problems += [f"probe: {p}" for p in clean(probe)]
    before = opening - probe.truth.front_m
    lo, hi = END_BEFORE_MIDDLE_M
    if not lo <= before <= hi:
        problems.append(f"probe: front tip {before:.3f} m before the opening's middle")
    if probe.truth.path_choices:
        problems.append(f"probe: a tee still decided: {dict(probe.truth.path_choices)}")
    if stuck:
        problems.append(f"stuck events {stuck}")
    return problems


def through(session: Session, way: str) -> tuple[Run, str]:
    """The T-joint PAB from where the probe left the robot; the segment it must end in."""
    if way == "straight":
        return session.run("t-joint.yaml", {"direction": "straight"}), "after"
    if way in ("left", "right"):
        return session.run("t-joint.yaml", {"direction": way}), "branch"
    return session.run(str(TREES / "lib" / "turn.yaml"), {"roll": ROLL[way]}), "branch"


CASES = [
    # side, diameter, seed, link faults; straight on afterwards in each
    ("left", "63 mm", 0, False),  # the bundled scenarios/t-joint.yaml
    ("left", "63 mm", 1, True),
    ("right", "55 mm", 2, True),
    ("up", "63 mm", 3, True),
    ("down", "55 mm", 4, False),
    ("right", "51 mm", 5, True),
    ("down", "51 mm", 6, True),
]


@pytest.mark.slow
@pytest.mark.parametrize(
    ("side", "diameter", "seed", "faults"),
    CASES,
    ids=[f"{s}-{d.replace(' ', '')}-seed{n}{'-faults' if f else ''}" for s, d, n, f in CASES],
)
def test_probe_finds_the_side_and_the_tee_is_passed_both_ways(
    side: str, diameter: str, seed: int, faults: bool, tmp_path: Path
) -> None:
    net = network(tmp_path, side, diameter)
    link_faults = LINK_FAULTS if faults else None
    failures: dict[str, list[str]] = {}
    for way in (side, "straight"):
        session, to_tee, probe, found, opening = probed(net, seed, link_faults)
        try:
            problems = probe_problems(session.network, to_tee, probe, opening, session.stuck())
            if found != side:
                problems.append(f"probe found {found!r}, the branch leaves {side}")
            run, segment = through(session, way)
        finally:
            session.close()
        problems += [f"{way}: {p}" for p in clean(run, refusals=False)]
        wrong = {m: s for m, s in run.truth.module_segment.items() if s != segment}
        if wrong:
            problems.append(f"{way}: modules not in {segment!r}: {wrong}")
        if problems:
            failures[way] = problems
    assert not failures, failures


# -- other pipes near the tee ----------------------------------------------------------

NEAR_TEE = """\
schema_version: 1
name: NAME
diameter: 63 mm
tether_drag_per_metre: 0.2 N
segments:
  - {id: before, type: straight, length: 2 m}
  - id: tee
    type: tee
    branch:
      BRANCH
      segments:
        BRANCH_SEGMENTS
  - AFTER
"""


def near_tee(tmp: Path, name: str, branch: str, branch_segments: str, after: str) -> Path:
    text = NEAR_TEE.replace("NAME", name).replace("BRANCH_SEGMENTS", branch_segments)
    path = tmp / f"{name}.yaml"
    path.write_text(text.replace("BRANCH", branch).replace("AFTER", after))
    return path


STRAIGHT_BRANCH = "- {id: branch, type: straight, length: 2 m}"


@pytest.mark.slow
def test_a_bend_just_past_the_tee_blocks_a_wrong_side_and_the_side_is_still_found(
    tmp_path: Path,
) -> None:
    # A bend to the right 0.1 m past the tee (the straight drive stops over the opening
    # before it): steered left the front half is blocked at the bend (a probe that tells
    # nothing), steered right it enters the bend but the IMU does not turn within the
    # probe; up takes the branch.
    net = near_tee(
        tmp_path,
        "tee-then-bend",
        "direction: up",
        STRAIGHT_BRANCH,
        "{id: gap, type: straight, length: 100 mm}\n"
        "  - {id: bend, type: bend, direction: right, radius: 90 mm}\n"
        "  - {id: after, type: straight, length: 1 m}",
    )
    session, _to_tee, probe, found, opening = probed(net, 7, LINK_FAULTS)
    try:
        stuck = session.stuck()
    finally:
        session.close()
    assert found == "up"
    assert clean(probe) == []
    assert "front:bend" in stuck  # a probe that was blocked, and told nothing
    assert opening - probe.truth.front_m > 0


@pytest.mark.slow
def test_a_branch_at_no_cardinal_roll_is_none(tmp_path: Path) -> None:
    net = near_tee(
        tmp_path,
        "tee-45",
        "roll: 45 deg",
        STRAIGHT_BRANCH,
        "{id: after, type: straight, length: 2 m}",
    )
    session, _to_tee, probe, found, opening = probed(net, 8, None)
    session.close()
    assert found == "none"
    assert clean(probe) == []
    lo, hi = END_BEFORE_MIDDLE_M
    assert lo <= opening - probe.truth.front_m <= hi


# -- failing cleanly -----------------------------------------------------------------------


@pytest.mark.slow
def test_a_bend_just_inside_the_branch_cannot_be_told_and_fails_holding(tmp_path: Path) -> None:
    # The front half takes the branch but is blocked by a bend in it before the IMU turns;
    # every other side goes on straight: no side turned and one stopped short.
    net = near_tee(
        tmp_path,
        "tee-branch-bend",
        "direction: left",
        "- {id: branch, type: straight, length: 50 mm}\n"
        "        - {id: bend, type: bend, direction: up, radius: 90 mm}\n"
        "        - {id: branch-2, type: straight, length: 1 m}",
        "{id: after, type: straight, length: 2 m}",
    )
    session, _to_tee, probe, found, opening = probed(net, 9, None)
    try:
        reason = session.sup.safe_state_reason
    finally:
        session.close()
    assert not probe.result.succeeded
    assert found == ""
    assert reason is not None and "the branch's side cannot be told" in reason
    assert all(h.clamped for h in probe.truth.halves.values())
    assert not probe.counters.violations and not probe.counters.damage
    assert not probe.counters.slip_events
    assert probe.truth.velocity_mps == 0.0
    assert opening - probe.truth.front_m > 0


def test_no_opening_fails_at_once_holding_without_moving() -> None:
    session = Session(SCENARIOS / "straight.yaml", start_m=1.0, seed=10)
    try:
        before = session.sim.truth().front_m
        probe = session.run("probe-tee.yaml", {})
        reason = session.sup.safe_state_reason
    finally:
        session.close()
    assert not probe.result.succeeded
    assert probe.reason == (
        "off the opening: front half not over an opening: no front joint off the wall"
    )
    assert reason is not None and reason.startswith("probe-tee PAB failed: off the opening")
    assert probe.truth.front_m == before
    assert all(h.clamped for h in probe.truth.halves.values())
    assert probe.truth.halves[Half.FRONT].clamped
    assert not probe.counters.violations and not probe.counters.damage
    assert not probe.refusals
