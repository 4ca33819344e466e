"""Run a planned mission: one tree, the localiser beside it, a trace, a result.

:func:`run_mission` builds the plan's tree (:func:`~pirate_bt.task.planner.mission_tree_spec`)
on the supervisor and the run's clock, and runs it with the
:class:`~pirate_bt.runner.Runner`. Around every tick:

- before: the supervisor's tick (it polls the robot and drains operator input);
- after: the :class:`~pirate_bt.task.localise.Localiser` takes the new state. If
  belief and map disagree, it clears the ``map_ok`` blackboard key; on the next
  tick the mission's guard fails, the tree stops, and the runner puts the robot
  in its safe state. The result names the localiser's reason.
- after: the trace records the tick, with the state, the supervisor's verdicts,
  the link's health and, under ``sim``, the simulator's counters and the
  ``task.belief_m`` / ``task.truth_m`` / ``task.error_m`` values.

The mission reaches the robot only through the supervisor; creating the
simulator or opening a port is the caller's business (``pirate-bt mission``).
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TextIO

import py_trees

from pirate_bt.clock import Clock
from pirate_bt.robot.description import RobotDescription
from pirate_bt.runner import Runner, RunResult
from pirate_bt.task.localise import Fix, Localiser
from pirate_bt.task.planner import MAP_OK_KEY, MissionPlan, mission_tree_spec
from pirate_bt.trace.attach import counter_values

__all__ = ["MissionResult", "Sample", "TimelineEntry", "estimate_time_s", "run_mission"]

_log = logging.getLogger(__name__)


@dataclass(frozen=True, slots=True)
class TimelineEntry:
    """A PAB of the chain starting (or the mission ending).

    Attributes:
        time_s: Clock time since the start of the run.
        label: The PAB's node name (``03 bend right (bend-a) (line 6)``).
        belief_m: Belief when it started.
        truth_m: Simulator truth then, when known.
    """

    time_s: float
    label: str
    belief_m: float
    truth_m: float | None


@dataclass(frozen=True, slots=True)
class Sample:
    """Belief and truth at one tick (for the report's plot)."""

    time_s: float
    belief_m: float
    truth_m: float | None


@dataclass
class MissionResult:
    """How a mission went.

    Attributes:
        plan: The plan that ran.
        run: The runner's result.
        reason: Why it ended, for people (the localiser's reason on a mismatch).
        fixes: Feature fixes of the localiser.
        timeline: When each PAB started.
        samples: Belief and truth over time (every tick with a new state).
        belief_m: Final belief.
        truth_m: Final truth, when simulated.
        odometry_m: Distance driven, by odometry.
        sim: Final simulator counters, when simulated.
        trace_path: The trace written, if any.
        tree: The mission tree (for diagrams).
    """

    plan: MissionPlan
    run: RunResult
    reason: str
    fixes: list[Fix]
    timeline: list[TimelineEntry]
    samples: list[Sample]
    belief_m: float
    truth_m: float | None
    odometry_m: float
    sim: Mapping[str, float] = field(default_factory=dict)
    trace_path: Path | None = None
    tree: Any = None
    mismatch: str | None = None
    start_s: float = 0.0
    """Clock time at the start of the run (fix times are clock times)."""

    @property
    def succeeded(self) -> bool:
        return self.run.succeeded

    @property
    def final_error_m(self) -> float | None:
        return None if self.truth_m is None else self.belief_m - self.truth_m

    @property
    def max_fix_error_m(self) -> float | None:
        """Largest belief error right after a fix (``None`` without truth or fixes)."""
        errors = [abs(f.error_after_m) for f in self.fixes if f.error_after_m is not None]
        return max(errors) if errors else None

    @property
    def max_error_m(self) -> float | None:
        """Largest belief error over the whole run."""
        errors = [abs(s.belief_m - s.truth_m) for s in self.samples if s.truth_m is not None]
        return max(errors) if errors else None


def estimate_time_s(plan: MissionPlan, nominal_speed_mps: float) -> float:
    """A generous time limit for a mission: slow driving plus two minutes per feature."""
    slow = max(nominal_speed_mps * plan.contract.slow_factor, 1e-3)
    pauses = sum(p.params.get("duration", 0.0) for p in plan.pabs if p.pab == "pause")
    features = sum(1 for p in plan.pabs if p.pab in ("bend", "t-joint"))
    return float(2.0 * plan.distance_m / slow + 120.0 * features + pauses + 60.0)


def run_mission(
    plan: MissionPlan,
    robot: RobotDescription,
    supervisor: Any,
    clock: Clock,
    *,
    trees_dir: Path | None = None,
    truth: Callable[[], float | None] | None = None,
    counters: Callable[[], Any] | None = None,
    trace_path: Path | None = None,
    scenario: str | None = None,
    seed: int | None = None,
    live: bool = False,
    live_stream: TextIO | None = None,
    period_s: float = 0.05,
    max_time_s: float | None = None,
    realtime: bool = False,
) -> MissionResult:
    """Run a planned mission on a robot (or the simulator) behind its supervisor.

    Args:
        plan: The plan.
        robot: The robot description.
        supervisor: The safety supervisor holding the connected robot.
        clock: The run's clock (a ``SimClock`` for the simulator).
        trees_dir: Where the PAB trees are (default: bundled).
        truth: The simulator's front-tip truth, for the trace and the report.
        counters: The simulator's counters (``SimCounters``), for the trace.
        trace_path: Write a trace here (format by suffix).
        scenario: Network name for the trace header.
        seed: Simulator seed for the trace header.
        live: Show the tree live on ``live_stream`` (standard error).
        live_stream: Where the live view draws.
        period_s: Tick period.
        max_time_s: Time limit (default: :func:`estimate_time_s`).
        realtime: Pace a simulated run to wall time.

    Returns:
        The result; a failed mission is a result, not an exception.

    Raises:
        ValidationFailed: the PAB trees do not load with the plan's parameters.
        ConfigurationError: a PAB tree is missing.
    """
    from pirate_bt.treefile import load_tree

    spec = mission_tree_spec(plan, trees_dir, robot.motion.nominal_speed)
    loaded = load_tree(spec, robot=robot, clock=clock, supervisor=supervisor)
    limit = max_time_s or estimate_time_s(plan, robot.motion.nominal_speed)
    reason_box = ["mission ended without success"]
    runner = Runner(
        loaded,
        clock=clock,
        period_s=period_s,
        max_time_s=limit,
        realtime=realtime,
        safe_state=lambda: supervisor.safe_state(reason_box[0]),
    )
    localiser = Localiser(plan, robot, truth=truth)
    start_s = clock.now()
    timeline: list[TimelineEntry] = []
    samples: list[Sample] = []
    route_node = runner.tree.root.children[-1]
    current: list[str | None] = [None]
    blackboard = py_trees.blackboard.Client(name="localiser")
    blackboard.register_key(MAP_OK_KEY, access=py_trees.common.Access.WRITE)

    def before(_info: Any) -> None:
        supervisor.tick()

    def after(_info: Any) -> None:
        state = supervisor.state()
        localiser.update(state)
        now = clock.now() - start_s
        if state is not None and (not samples or samples[-1].time_s != now):
            samples.append(Sample(round(now, 4), localiser.belief_m, localiser.truth_m))
        child = getattr(route_node, "current_child", None)
        name = child.name if child is not None and child.status.name == "RUNNING" else None
        if name is not None and name != current[0]:
            timeline.append(TimelineEntry(now, name, localiser.belief_m, localiser.truth_m))
        current[0] = name or current[0]
        if localiser.mismatch is not None and blackboard.get(MAP_OK_KEY):
            reason_box[0] = localiser.mismatch
            blackboard.set(MAP_OK_KEY, False)

    runner.add_pre_tick(before)
    runner.add_post_tick(after)
    if trace_path is not None:
        from pirate_bt.trace import attach_trace, supervised_extras

        extras = supervised_extras(supervisor, counters=counters, more=localiser.values)
        trace_path.parent.mkdir(parents=True, exist_ok=True)
        attach_trace(
            runner,
            trace_path,
            extras=extras,
            robot=robot,
            scenario=scenario,
            seed=seed,
            meta={"route": plan.route.to_json(), "plan": plan.describe()},
        )
    if live:
        from pirate_bt.trace import attach_live_view

        attach_live_view(runner, live_stream)
    result = runner.run()
    localiser.update(supervisor.state())
    reason = result.message
    if localiser.mismatch is not None:
        reason = localiser.mismatch
    end = clock.now() - start_s
    timeline.append(
        TimelineEntry(end, f"end: {result.outcome}", localiser.belief_m, localiser.truth_m)
    )
    return MissionResult(
        plan=plan,
        run=result,
        reason=reason,
        fixes=list(localiser.fixes),
        timeline=timeline,
        samples=samples,
        belief_m=localiser.belief_m,
        truth_m=localiser.truth_m,
        odometry_m=localiser.distance_m,
        sim=counter_values(counters() if counters is not None else None),
        trace_path=trace_path,
        tree=runner.tree,
        mismatch=localiser.mismatch,
        start_s=start_s,
    )
