"""The backward PABs end to end (issues 28 and 30): forwards past a feature, then back.

Each case runs the forward PAB and then its backward twin in one simulated session
(runner -> supervisor -> link -> simulator, typical sensor noise, with and without
link faults), as a mission or a navigator backing out of a dead end would: the
backward PAB starts where the forward one left the robot. A case passes on the
simulator's truth: both PABs succeeded, every module is back on the segment before
the feature (a bend: the front tip too), both halves clamp, no violation, no damage,
and the only stuck events are the ones the turn PABs cause on purpose (the half that
holds blocks at the turn and ends ``drive until: blocked``: the rear half forwards,
the front half backwards; into a tee's branch the forward drive ends when the robot
turns, before the rear half reaches the branch's opening, so only the backward block
is left). Where the backward PAB leaves the robot (its contract,
docs/pabs.md) is checked against the numbers measured there.

A tee's branch is left backwards only where the robot fits (docs/pabs.md): the
branch cases run in a 51 mm tee; in the bundled 63 mm tee the PAB fails cleanly.
"""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import py_trees
import pytest

from pirate_bt.behaviours.base import BuildContext
from pirate_bt.behaviours.primitives import last_failure
from pirate_bt.clock import SimClock
from pirate_bt.link import open_link
from pirate_bt.pipes import Network, Piece, PieceKind, load_network
from pirate_bt.resources import data_dir
from pirate_bt.robot import Half, load_robot
from pirate_bt.robot.description import Role
from pirate_bt.runner import Runner, RunResult
from pirate_bt.safety import Mode, Resume, Supervisor
from pirate_bt.safety.factory import wait_for_state
from pirate_bt.sim import SensorNoise, SimCounters, SimTruth, Simulator
from pirate_bt.sim.counters import EventKind
from pirate_bt.task.plan import PabContract
from pirate_bt.treefile import build, load_tree
from pirate_bt.treefile.loader import LoadedTree

ROBOT = load_robot()
TREES = data_dir("trees")
SCENARIOS = data_dir("scenarios")
SEEDS = range(4)
LINK_FAULTS = "drop=0.05,corrupt=0.01"
CONTRACT = PabContract()
TOLERANCE_M = 0.015
"""As the forward contract's (pirate_bt.task.calibrate.DEFAULT_TOLERANCE_M)."""

FRONT_TRAIL_M = sum(m.length for m in ROBOT.modules if m.half is Half.FRONT)
"""The front half's trailing end behind the front tip (0.22 m): it blocks at the turn."""
BEND_MODULES_M = {
    m.name: sum(x.length for x in ROBOT.modules[:i]) + m.length / 2
    for i, m in enumerate(ROBOT.modules)
    if m.role is Role.BEND
}
"""Each bend module's centre behind the front tip."""

# the contract of docs/pabs.md (measured there, noiseless, seed 0)
TURN_BACK_OVERRUN_M = 0.011
TEE_BACK_EXIT_M = 0.300


@pytest.fixture(autouse=True)
def quiet(caplog: pytest.LogCaptureFixture) -> Iterator[None]:
    caplog.set_level(logging.ERROR)
    py_trees.blackboard.Blackboard.clear()
    yield


def tee_network(tmp: Path, direction: str, diameter: str) -> Path:
    """The bundled t-joint scenario with its branch to ``direction`` in ``diameter`` pipe."""
    text = (SCENARIOS / "t-joint.yaml").read_text()
    text = text.replace("direction: left", f"direction: {direction}")
    text = text.replace("diameter: 63 mm", f"diameter: {diameter}")
    name = f"t-joint-{direction}-{diameter.replace(' ', '')}"
    path = tmp / f"{name}.yaml"
    path.write_text(text.replace("name: t-joint", f"name: {name}"))
    return path


@pytest.fixture(scope="module")
def nets(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    tmp = tmp_path_factory.mktemp("net")
    out = {f"bend-{d}": SCENARIOS / f"bend-{d}.yaml" for d in ("up", "down", "left", "right")}
    out["t-joint"] = SCENARIOS / "t-joint.yaml"
    out["t-joint-63-right"] = tee_network(tmp, "right", "63 mm")
    out["t-joint-51-left"] = tee_network(tmp, "left", "51 mm")
    out["t-joint-51-right"] = tee_network(tmp, "right", "51 mm")
    out["straight"] = SCENARIOS / "straight.yaml"
    return out


_LOADED: dict[tuple[str, tuple[tuple[str, str], ...]], LoadedTree] = {}


def loaded(tree: str, params: dict[str, str]) -> LoadedTree:
    key = (tree, tuple(sorted(params.items())))
    if key not in _LOADED:  # TREES / an absolute path is that path
        _LOADED[key] = load_tree(TREES / tree, robot=ROBOT, params=params, params_from_text=True)
    return _LOADED[key]


@dataclass
class Run:
    result: RunResult
    reason: str | None
    truth: SimTruth
    counters: SimCounters
    refusals: list[str]
    """Every command of the run the supervisor refused (node, reason)."""


Operator = Callable[[Supervisor, Any], None]


class Session:
    """One simulated robot in one network; PABs run one after the other on it."""

    def __init__(
        self,
        network: Path,
        *,
        start_m: float,
        seed: int = 0,
        link_faults: str | None = None,
        mode: Mode = Mode.AUTONOMOUS,
    ) -> None:
        self.network: Network = load_network(network)
        self.clock = SimClock()
        self.sim = Simulator(
            self.network,
            ROBOT,
            seed=seed,
            clock=self.clock,
            noise=SensorNoise.typical(),
            start_m=start_m,
        )
        faults = f"{link_faults},seed={seed}" if link_faults else None
        self.link = open_link(self.sim.url, ROBOT, self.clock, faults=faults)
        wait_for_state(self.link, self.clock, 5.0)
        self.sup = Supervisor(self.link, self.clock, mode=mode)
        self._refusals: list[str] = []
        self.sup.add_listener(
            lambda v: self._refusals.append(f"{v.node_name}: {v.reason}") if v.refused else None
        )

    def run(self, tree: str, params: dict[str, str], operator: Operator | None = None) -> Run:
        py_trees.blackboard.Blackboard.clear()
        checked = loaded(tree, params)
        context = BuildContext(robot=ROBOT, clock=self.clock, supervisor=self.sup)
        built = dataclasses.replace(checked, root=build(checked.spec, context))
        runner = Runner(
            built,
            clock=self.clock,
            period_s=0.05,
            max_time_s=300.0,
            safe_state=lambda: self.sup.safe_state("tree run ended without success"),
        )
        runner.add_pre_tick(lambda _info: self.sup.tick())
        if operator is not None:
            runner.add_pre_tick(lambda info: operator(self.sup, info))
        self._refusals.clear()
        result = runner.run()
        reason = None if result.succeeded else last_failure(runner.tree.root)
        refusals = list(self._refusals)
        return Run(result, reason, self.sim.truth(), self.sim.counters(), refusals)

    def stuck(self) -> list[str]:
        return [e.detail for e in self.sim.events() if e.kind is EventKind.STUCK]

    def close(self) -> None:
        self.link.close()
        self.sim.close()


def first_feature(network: Network, kind: PieceKind) -> Piece:
    return next(p for p in network.path({}).pieces if p.kind is kind)


def branch_turn(network: Network) -> Piece:
    tee = first_feature(network, PieceKind.TEE)
    path = network.path({tee.segment: "branch"})
    return next(p for p in path.pieces if p.kind is PieceKind.TEE_TURN)


def clean(run: Run, *, refusals: bool = True) -> list[str]:
    """Success, no violation, damage or slip, both halves clamped; with ``refusals``,
    no command refused either (the backward PABs need no rule bent: docs/safety.md)."""
    problems: list[str] = []
    if not run.result.succeeded:
        problems.append(f"{run.result.message}: {run.reason}")
    if run.counters.violations:
        problems.append(f"violations {dict(run.counters.violations)}")
    if run.counters.damage:
        problems.append(f"damage {dict(run.counters.damage)}")
    if run.counters.slip_events:
        problems.append(f"{run.counters.slip_events} slip events")
    if not all(h.clamped for h in run.truth.halves.values()):
        problems.append("not both halves clamped at the end")
    if refusals and run.refusals:
        problems.append(f"refused: {run.refusals}")
    return problems


def on_segment(run: Run, network: Network, segment: str, *, tip: bool) -> list[str]:
    """Every module (and with ``tip`` the front tip) on ``segment`` of the main line."""
    problems: list[str] = []
    wrong = {m: s for m, s in run.truth.module_segment.items() if s != segment}
    if wrong:
        problems.append(f"modules not on {segment!r}: {wrong}")
    if tip and network.path({}).piece_at(run.truth.front_m).segment != segment:
        problems.append(f"front tip at {run.truth.front_m:.3f} m, not on {segment!r}")
    if run.truth.path_choices:
        problems.append(f"a tee still decided: {dict(run.truth.path_choices)}")
    return problems


def start_before(piece: Piece) -> float:
    """Where a mission starts a forward PAB: the approach margin before the feature."""
    return piece.start_m - CONTRACT.approach_m


# -- a bend, forwards then backwards, in every roll -------------------------------------

BENDS = {"up": "0 deg", "down": "180 deg", "left": "-90 deg", "right": "90 deg"}


def bend_forward_and_back(
    nets: dict[str, Path], direction: str, seed: int, faults: str | None
) -> list[str]:
    net = nets[f"bend-{direction}"]
    roll = {"roll": BENDS[direction]}
    session = Session(net, start_m=1.75, seed=seed, link_faults=faults)
    try:
        bend = first_feature(session.network, PieceKind.BEND)
        forward = session.run("bend.yaml", roll)
        problems = [f"forward: {p}" for p in clean(forward, refusals=False)]
        if problems:
            return problems
        back = session.run("bend-back.yaml", roll)
        problems += [f"back: {p}" for p in clean(back)]
        problems += on_segment(back, session.network, "before", tip=True)
        stuck = session.stuck()
    finally:
        session.close()
    if stuck != ["rear:bend", "front:bend"]:
        problems.append(f"stuck events {stuck}: only the two blocks at the turn expected")
    end = bend.end_m + FRONT_TRAIL_M - CONTRACT.follow_m - TURN_BACK_OVERRUN_M
    if abs(back.truth.front_m - end) > TOLERANCE_M:
        problems.append(f"front tip at {back.truth.front_m:.3f} m, contract {end:.3f} m")
    return problems


@pytest.mark.parametrize("faults", [None, LINK_FAULTS], ids=["clean", "link-faults"])
@pytest.mark.parametrize("direction", list(BENDS))
def test_bend_forwards_then_backwards(
    direction: str, faults: str | None, nets: dict[str, Path]
) -> None:
    failures = {}
    for seed in SEEDS:
        problems = bend_forward_and_back(nets, direction, seed, faults)
        if problems:
            failures[seed] = problems
    assert not failures, f"bend {direction} failed for seeds {sorted(failures)}: {failures}"


# -- a tee: straight through and back, into a branch and back out ------------------------


@pytest.mark.parametrize("faults", [None, LINK_FAULTS], ids=["clean", "link-faults"])
def test_tee_straight_through_and_back(faults: str | None, nets: dict[str, Path]) -> None:
    failures: dict[int, list[str]] = {}
    for seed in SEEDS:
        session = Session(nets["t-joint"], start_m=1.75, seed=seed, link_faults=faults)
        try:
            tee = first_feature(session.network, PieceKind.TEE)
            forward = session.run("t-joint.yaml", {"direction": "straight"})
            back = session.run("t-joint-back.yaml", {"direction": "straight"})
            stuck = session.stuck()
        finally:
            session.close()
        assert tee.opening_m is not None
        problems = [f"forward: {p}" for p in clean(forward, refusals=False)]
        problems += [f"back: {p}" for p in clean(back)]
        problems += on_segment(back, session.network, "before", tip=False)
        if stuck:
            problems.append(f"stuck events {stuck}")
        # every bend module before the opening's near edge: the next PAB clamps at once
        near_edge = tee.opening_m - tee.diameter_start_m / 2
        first_bend_m = back.truth.front_m - min(BEND_MODULES_M.values())
        if first_bend_m >= near_edge:
            problems.append(f"a bend module {first_bend_m - near_edge:.3f} m into the opening")
        end = tee.opening_m + FRONT_TRAIL_M - TEE_BACK_EXIT_M
        if abs(back.truth.front_m - end) > TOLERANCE_M:
            problems.append(f"front tip at {back.truth.front_m:.3f} m, contract {end:.3f} m")
        if problems:
            failures[seed] = problems
    assert not failures, f"failed for seeds {sorted(failures)}: {failures}"


@pytest.mark.parametrize("faults", [None, LINK_FAULTS], ids=["clean", "link-faults"])
@pytest.mark.parametrize("direction", ["left", "right"])
def test_into_a_branch_and_back_out(
    direction: str, faults: str | None, nets: dict[str, Path]
) -> None:
    failures: dict[int, list[str]] = {}
    way = {"direction": direction}
    for seed in SEEDS:
        net = nets[f"t-joint-51-{direction}"]
        session = Session(net, start_m=1.75, seed=seed, link_faults=faults)
        try:
            turn = branch_turn(session.network)
            forward = session.run("t-joint.yaml", way)
            in_branch = forward.truth.module_segment["rear"] == "branch"
            back = session.run("t-joint-back.yaml", way)
            stuck = session.stuck()
        finally:
            session.close()
        problems = [f"forward: {p}" for p in clean(forward, refusals=False)]
        if not in_branch:
            problems.append("the forward PAB did not take the branch")
        problems += [f"back: {p}" for p in clean(back)]
        problems += on_segment(back, session.network, "before", tip=True)
        # forwards, the drive in ends when the robot turns (the rear half never blocks:
        # in a tee of 65 mm and more it would be over the opening first); backwards the
        # front half blocks at the turn
        if stuck != ["front:tee"]:
            problems.append(f"stuck events {stuck}: only the front's block at the turn expected")
        end = turn.end_m + FRONT_TRAIL_M - CONTRACT.follow_m - TURN_BACK_OVERRUN_M
        if abs(back.truth.front_m - end) > TOLERANCE_M:
            problems.append(f"front tip at {back.truth.front_m:.3f} m, contract {end:.3f} m")
        if problems:
            failures[seed] = problems
    assert not failures, f"failed for seeds {sorted(failures)}: {failures}"


# What docs/pabs.md tells the operator to do after a branch too wide to back out of.
BACK_INTO_BRANCH = """\
name: back into the branch
blackboard:
  steer_sign: {type: integer, default: 1}
root:
  type: sequence
  children:
    - {type: subtree, name: release rear, ref: LIB/release-rear.yaml}
    - {type: align_roll, name: align rear, half: rear, roll: 90 deg}
    - {type: bend, name: steer rear, module: rear, angle: 40 deg, sign_from: steer_sign}
    - {type: drive, name: into the branch, velocity: 80 mm/s, distance: 300 mm}
    - {type: subtree, name: clamp rear, ref: LIB/clamp-rear.yaml}
"""


def test_a_branch_too_wide_to_back_out_of_fails_cleanly(
    nets: dict[str, Path], tmp_path: Path
) -> None:
    # 63 mm: when the front half blocks at the branch's turn, bend III is still over
    # the opening (docs/pabs.md): the rear half cannot clamp behind the turn.
    tree = tmp_path / "back-into-branch.yaml"
    tree.write_text(BACK_INTO_BRANCH.replace("LIB", str(TREES / "lib")))
    session = Session(nets["t-joint-63-right"], start_m=1.75, seed=1)
    try:
        turn = branch_turn(session.network)
        assert clean(session.run("t-joint.yaml", {"direction": "right"}), refusals=False) == []
        back = session.run("t-joint-back.yaml", {"direction": "right"})
        in_safe_state = session.sup.in_safe_state
        # the operator resumes and drives the rear half back into the branch
        session.sup.apply(Resume())
        again = session.run(str(tree), {})
    finally:
        session.close()
    assert not back.result.succeeded and in_safe_state
    assert back.reason is not None
    assert "clamp rear half: no wall: bend_3" in back.reason and "over an opening" in back.reason
    assert not back.counters.violations and not back.counters.damage
    assert back.truth.halves[Half.FRONT].clamped  # the front half holds in the branch
    assert back.truth.front_m == pytest.approx(turn.end_m + FRONT_TRAIL_M, abs=0.005)
    assert back.truth.velocity_mps == 0.0
    assert clean(again) == []
    assert set(again.truth.module_segment.values()) == {"branch"}


# -- failing cleanly -----------------------------------------------------------------------


def test_bend_back_with_no_bend_behind_fails_with_both_halves_holding(
    nets: dict[str, Path],
) -> None:
    session = Session(nets["straight"], start_m=4.0, seed=2)
    try:
        back = session.run("bend-back.yaml", {"roll": "90 deg"})
        in_safe_state = session.sup.in_safe_state
        safe_reason = session.sup.safe_state_reason
    finally:
        session.close()
    assert not back.result.succeeded and in_safe_state
    assert back.reason is not None and "no feature (blocked) within 3 m" in back.reason
    assert safe_reason is not None and "no feature (blocked) within 3 m" in safe_reason
    assert safe_reason.startswith("bend-back PAB failed: rear into turn")
    assert all(h.clamped for h in back.truth.halves.values())  # the rear clamped again
    assert not back.counters.violations and not back.counters.damage
    assert back.counters.stuck_events == 0
    assert 4.0 - back.truth.front_m == pytest.approx(3.0, abs=0.03)
    assert back.truth.velocity_mps == 0.0


def test_bend_back_in_the_wrong_plane_fails_cleanly(nets: dict[str, Path]) -> None:
    # back through a right-hand bend with the halves in the up-down plane: the rear
    # half blocks at the turn (it is not aligned), so the front half cannot follow
    session = Session(nets["bend-right"], start_m=1.75, seed=3)
    try:
        assert clean(session.run("bend.yaml", {"roll": "90 deg"}), refusals=False) == []
        back = session.run("bend-back.yaml", {"roll": "0 deg"})
        in_safe_state = session.sup.in_safe_state
    finally:
        session.close()
    assert not back.result.succeeded and in_safe_state
    assert back.reason is not None and "blocked" in back.reason
    assert not back.counters.violations and not back.counters.damage
    assert any(h.clamped for h in back.truth.halves.values())
    assert back.truth.velocity_mps == 0.0


def test_supervised_bend_back_holds_at_every_confirmation_point(nets: dict[str, Path]) -> None:
    asked: list[str] = []

    def operator(sup: Supervisor, info: Any) -> None:
        for step in sup.pending_confirmations():
            if step not in asked:
                asked.append(step)
        if info.tick % 20 == 0 and sup.pending_confirmations():
            sup.confirm()

    session = Session(nets["bend-down"], start_m=1.75, seed=4, mode=Mode.SUPERVISED)
    try:
        session.run("bend.yaml", {"roll": "180 deg"}, operator)
        asked.clear()
        back = session.run("bend-back.yaml", {"roll": "180 deg"}, operator)
    finally:
        session.close()
    assert clean(back) == []
    assert asked == [
        "hold the pipe with both halves",
        "release the rear half and steer it into the turn behind",
        "drive the rear half back into the turn",
        "clamp the rear half behind the turn",
        "bring the front half back through the turn",
    ]
