"""Calibrate the PAB contract: run each PAB once on the simulator and measure it.

The planner places every PAB on the map open-loop: it needs to know where a PAB
leaves the robot (:class:`~pirate_bt.task.planner.PabContract`). Those numbers
belong to the PAB trees in ``trees/``: change a tree (a drive distance, the way a
tee is crossed) and the robot ends somewhere else. Measured once by hand, they
drift silently; the demo then drives the robot into a bend.

So the numbers are *derived*: :func:`calibrate` runs each PAB once in its bundled
scenario on the in-process simulator (the same runner, supervisor and wire
protocol as a mission, no sensor noise, seed 0), starting where the planner
starts it, and measures where the front tip really ends. The constants stay in
the code (planning stays fast and needs no simulation);
``tests/test_task_contract.py`` runs this calibration and fails, naming the
constant and the measured value, when one is off by more than a small
tolerance. Print the numbers with::

    python -m pirate_bt.task.calibrate

Each measurement is also checked for the thing the planner relies on most: at
the end of a bend or T-joint PAB every bend module is past the feature (off a
tee's opening), so the next PAB can clamp at once.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import py_trees

from pirate_bt.pipes import Network, Piece, PieceKind, load_network
from pirate_bt.robot.description import RobotDescription
from pirate_bt.task.planner import PabContract, rear_lead_m

__all__ = ["Calibration", "Measurement", "calibrate", "check_contract"]

_log = logging.getLogger(__name__)

DEFAULT_TOLERANCE_M = 0.015
"""How far a contract constant may be from its measurement (a few ticks of driving)."""


@dataclass(frozen=True)
class Measurement:
    """One PAB run on the simulator.

    Attributes:
        case: ``straight``, ``bend-up`` ..., ``tee-straight``, ``tee-left``.
        tree: The PAB tree file (under ``trees/``).
        params: Its parameters (command-line text).
        scenario: The bundled network it ran in.
        start_m: Front tip at the start (where the planner starts it).
        end_m: Front tip at the end.
        feature_m: Reference point of the feature: the start of the turn (bends,
            tee turns) or the middle of the opening (straight through a tee); the
            start position for the straight PAB.
        value_m: The contract quantity this run measures (see :class:`Calibration`).
        rear_clear_m: How far the last bend module ended past the feature (past the
            end of the turn, or past the far edge of a tee's opening); ``nan`` for
            the straight PAB.
        succeeded: The PAB succeeded.
        violations: Violations and damage events the simulator counted.
        message: The runner's result message.
    """

    case: str
    tree: str
    params: Mapping[str, str]
    scenario: str
    start_m: float
    end_m: float
    feature_m: float
    value_m: float
    rear_clear_m: float
    succeeded: bool
    violations: int
    message: str


@dataclass(frozen=True)
class Calibration:
    """The contract numbers measured on the simulator.

    Attributes:
        straight_overrun_m: The straight PAB drives this much more than its distance.
        turn_overrun_m: A turn PAB ends with the front tip at the turn's start + the
            rear half's lead offset + ``follow_m`` + this (worst of every bend
            orientation and the turn into a tee's branch).
        tee_exit_m: The straight-through T-joint PAB ends with the front tip at the
            opening's middle + the rear half's lead offset + this.
        measurements: Every run, for the report.
    """

    straight_overrun_m: float
    turn_overrun_m: float
    tee_exit_m: float
    measurements: tuple[Measurement, ...] = field(default_factory=tuple)

    def values(self) -> dict[str, float]:
        """The measured contract constants by :class:`PabContract` field name."""
        return {
            "straight_overrun_m": self.straight_overrun_m,
            "turn_overrun_m": self.turn_overrun_m,
            "tee_exit_m": self.tee_exit_m,
        }

    def describe(self, contract: PabContract | None = None) -> list[str]:
        """Lines for people: every run, then each constant beside its measurement."""
        contract = contract or PabContract()
        lines = [
            f"{'case':<13} {'start':>7} {'end':>7} {'feature':>8} {'value':>7} {'rear clear':>10}"
        ]
        for m in self.measurements:
            outcome = "" if m.succeeded and not m.violations else f"  FAILED: {m.message}"
            lines.append(
                f"{m.case:<13} {m.start_m:7.3f} {m.end_m:7.3f} {m.feature_m:8.3f}"
                f" {m.value_m:7.3f} {m.rear_clear_m:10.3f}{outcome}"
            )
        lines.append("")
        for name, value in self.values().items():
            have = float(getattr(contract, name))
            lines.append(f"{name:<19} measured {value:7.3f} m   contract {have:7.3f} m")
        return lines


# (case, tree, params, scenario)
_CASES: tuple[tuple[str, str, dict[str, str], str], ...] = (
    ("straight", "straight.yaml", {"distance": "1 m"}, "straight"),
    ("bend-up", "bend.yaml", {"roll": "0 deg"}, "bend-up"),
    ("bend-down", "bend.yaml", {"roll": "180 deg"}, "bend-down"),
    ("bend-left", "bend.yaml", {"roll": "-90 deg"}, "bend-left"),
    ("bend-right", "bend.yaml", {"roll": "90 deg"}, "bend-right"),
    ("tee-straight", "t-joint.yaml", {"direction": "straight"}, "t-joint"),
    ("tee-left", "t-joint.yaml", {"direction": "left"}, "t-joint"),
)

_STRAIGHT_M = 1.0


def _feature(network: Network, case: str) -> tuple[Piece | None, Piece | None]:
    """The feature a case passes and the piece the robot turns into (tee turns)."""
    if case == "straight":
        return None, None
    path = network.path({})
    first = next(p for p in path.pieces if p.kind in (PieceKind.BEND, PieceKind.TEE))
    if case == "tee-left":
        branch = network.path({first.segment: "branch"})
        turn = next(p for p in branch.pieces if p.kind is PieceKind.TEE_TURN)
        return first, turn
    return first, first


def _run_case(
    case: str,
    tree: str,
    params: dict[str, str],
    scenario: str,
    robot: RobotDescription,
    contract: PabContract,
    trees_dir: Path,
    scenarios_dir: Path,
    seed: int,
) -> Measurement:
    from pirate_bt.behaviours.primitives import last_failure
    from pirate_bt.clock import SimClock
    from pirate_bt.runner import Runner
    from pirate_bt.safety.factory import open_supervisor
    from pirate_bt.sim import Simulator
    from pirate_bt.treefile import load_tree

    network = load_network(scenarios_dir / f"{scenario}.yaml")
    feature, turn = _feature(network, case)
    start: float | None = None
    if feature is not None:
        start = feature.start_m - contract.approach_m
    py_trees.blackboard.Blackboard.clear()
    clock = SimClock()
    with Simulator(network, robot, seed=seed, clock=clock, start_m=start) as sim:
        supervisor = open_supervisor(robot, url=sim.url, clock=clock)
        try:
            start_m = sim.truth().front_m
            loaded = load_tree(
                trees_dir / tree,
                robot=robot,
                clock=clock,
                supervisor=supervisor,
                params=params,
                params_from_text=True,
            )
            runner = Runner.supervised(
                loaded,
                supervisor,
                clock=clock,
                end_reason=lambda: "calibration run failed",
                period_s=0.05,
                max_time_s=300.0,
            )
            result = runner.run()
            reason = None if result.succeeded else last_failure(runner.tree.root)
            truth = sim.truth()
            counters = sim.counters()
        finally:
            supervisor.close()
    end_m = truth.front_m
    lead = rear_lead_m(robot)
    behind = robot.behind_front_tip_m()  # the simulator's module positions
    last_bend_m = max(behind[m.name] for m in robot.all_bend_modules())
    rear_clear = math.nan
    if feature is None:
        reference = start_m
        value = end_m - start_m - _STRAIGHT_M
    elif case == "tee-straight":
        assert feature.opening_m is not None
        reference = feature.opening_m
        value = end_m - reference - lead
        far_edge = feature.opening_m + feature.diameter_start_m / 2
        rear_clear = end_m - last_bend_m - far_edge
    else:
        assert turn is not None
        reference = turn.start_m
        value = end_m - reference - lead - contract.follow_m
        rear_clear = end_m - last_bend_m - turn.end_m
    return Measurement(
        case=case,
        tree=tree,
        params=params,
        scenario=scenario,
        start_m=start_m,
        end_m=end_m,
        feature_m=reference,
        value_m=value,
        rear_clear_m=rear_clear,
        succeeded=result.succeeded,
        violations=counters.violation_count + counters.damage_count,
        message=f"{result.message}: {reason}" if reason else result.message,
    )


def calibrate(
    robot: RobotDescription | None = None,
    contract: PabContract | None = None,
    *,
    trees_dir: Path | None = None,
    scenarios_dir: Path | None = None,
    seed: int = 0,
) -> Calibration:
    """Run every PAB once in its bundled scenario on the simulator and measure it.

    Bend and T-joint PABs start where the planner starts them (the front tip
    ``contract.approach_m`` before the feature); the straight PAB drives 1 m from
    the entry.

    Args:
        robot: The robot description (default: the bundled 2018 robot).
        contract: The contract whose ``approach_m`` and ``follow_m`` the runs use
            (default: :class:`PabContract`).
        trees_dir: The PAB trees (default: the bundled ``trees/``).
        scenarios_dir: The scenarios (default: the bundled ``scenarios/``).
        seed: The simulator's seed (no sensor noise is added).

    Returns:
        The measured constants and every run.

    Raises:
        RuntimeError: a PAB failed in its own scenario (the numbers would mean
            nothing), with the run's reason.
    """
    from pirate_bt.resources import data_dir
    from pirate_bt.robot.loader import load_robot

    robot = robot or load_robot()
    contract = contract or PabContract()
    trees = trees_dir or data_dir("trees")
    scenarios = scenarios_dir or data_dir("scenarios")
    runs: list[Measurement] = []
    for case, tree, params, scenario in _CASES:
        run = _run_case(case, tree, params, scenario, robot, contract, trees, scenarios, seed)
        _log.info("calibration %s: front tip %.3f -> %.3f m", case, run.start_m, run.end_m)
        if not run.succeeded or run.violations:
            raise RuntimeError(
                f"calibration: the {case} PAB ({tree} {params}) did not pass cleanly in"
                f" scenarios/{scenario}.yaml: {run.message} ({run.violations} violations)"
            )
        runs.append(run)
    by_case = {m.case: m for m in runs}
    turns = [m.value_m for m in runs if m.case.startswith("bend") or m.case == "tee-left"]
    return Calibration(
        straight_overrun_m=by_case["straight"].value_m,
        # the worst case: a turn PAB that ends further on leaves less room before the
        # next feature
        turn_overrun_m=max(turns),
        tee_exit_m=by_case["tee-straight"].value_m,
        measurements=tuple(runs),
    )


def check_contract(
    calibration: Calibration,
    contract: PabContract | None = None,
    tolerance_m: float = DEFAULT_TOLERANCE_M,
) -> list[str]:
    """Every contract constant that is off its measurement by more than ``tolerance_m``.

    Returns:
        One message per drifted constant (empty when the contract holds), each
        naming the constant, its value, the measurement and what to do.
    """
    contract = contract or PabContract()
    problems: list[str] = []
    for name, measured in calibration.values().items():
        have = float(getattr(contract, name))
        if abs(have - measured) > tolerance_m:
            problems.append(
                f"PabContract.{name} = {have:.3f} m, but the PAB trees now end at"
                f" {measured:.3f} m on the simulator (off by {measured - have:+.3f} m, more"
                f" than {tolerance_m:.3f} m): a PAB tree changed where it leaves the robot;"
                f" set {name} = {measured:.3f} in pirate_bt/task/planner.py"
                " (numbers: python -m pirate_bt.task.calibrate)"
            )
    for m in calibration.measurements:
        if not math.isnan(m.rear_clear_m) and m.rear_clear_m <= 0.0:
            problems.append(
                f"the {m.case} PAB ends with its last bend module {-m.rear_clear_m:.3f} m"
                " short of the end of the feature (on it, or over the tee's opening): the"
                " next PAB could not clamp there"
            )
    return problems


def main() -> int:
    """Measure the contract and print it beside the constants (``python -m ...``)."""
    logging.basicConfig(level=logging.ERROR)
    calibration = calibrate()
    for line in calibration.describe():
        print(line)
    problems = check_contract(calibration)
    for problem in problems:
        print(problem)
    return 1 if problems else 0


if __name__ == "__main__":
    raise SystemExit(main())
