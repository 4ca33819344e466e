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

Each straight leg's distance is re-computed from the belief when it starts
(:func:`leg_distance_m`, written to the ``leg_distance`` blackboard key).

The mission reaches the robot only through the supervisor; creating the
simulator or opening a port is the caller's business: the public API's
(:func:`pirate_bt.simulate_mission`, :func:`pirate_bt.run_mission`), which
``pirate-bt mission`` calls. Going on after a stop (re-plan, return to start)
is :mod:`pirate_bt.task.replan`.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any, TextIO

import py_trees

from pirate_bt.behaviours.cause import path_of as route_path
from pirate_bt.clock import Clock
from pirate_bt.pipes import PieceKind
from pirate_bt.robot.description import RobotDescription
from pirate_bt.runner import Runner, RunResult, StopReason
from pirate_bt.safety.tally import VerdictTally
from pirate_bt.task.fixes import ShortLeg
from pirate_bt.task.localise import MAP_FRACTION, Localiser
from pirate_bt.task.mission_result import Leg, MissionResult, Sample, TimelineEntry
from pirate_bt.task.outcome import (
    PabOutcome,
    counted,
    explain_run,
    link_cause,
    map_cause,
    pab_outcomes,
)
from pirate_bt.task.plan import (
    LEG_DISTANCE_KEY,
    MAP_OK_KEY,
    MissionPlan,
    PlannedPab,
    short_leg,
)
from pirate_bt.task.slope_watch import SlopeWatch
from pirate_bt.task.tree import mission_tree_spec
from pirate_bt.task.where_believed import ended_short
from pirate_bt.trace.attach import counter_values
from pirate_bt.trace.coverage import attach_coverage

__all__ = [
    "Leg",
    "MissionResult",
    "Sample",
    "TimelineEntry",
    "estimate_time_s",
    "run_mission",
    "truth_of",
    "truth_on_map",
]

_log = logging.getLogger(__name__)


Observer = Callable[[Runner, Callable[[], dict[str, float]]], None]
"""What :func:`run_mission`'s ``observe`` is: ``observe(runner, localiser_values)``."""


def leg_distance_m(
    plan: MissionPlan, pab: PlannedPab, belief_m: float, localiser: Localiser
) -> tuple[float, str]:
    """The distance a straight leg drives when it starts at ``belief_m``, and why.

    A leg *to a place* (:attr:`PlannedPab.absolute`) drives from the belief to that
    place; a route's ``forward``/``inspect``/``back`` drives its own distance. A
    forward leg then stops short of the next feature on the map by the planner's
    margin plus what the map may be off by since the last fix
    (:meth:`Localiser.uncertainty_m`): it keeps its margin from where the feature
    really is, as far as the robot can know it. The PAB that passes the feature
    senses it, and drives the rest.

    Returns:
        ``(metres, why)``: negative backwards; ``why`` says what shortened it.
    """
    planned = pab.end_m - pab.start_m
    distance = pab.end_m - belief_m if pab.absolute else planned
    if planned < 0:
        return min(distance, 0.0), ""
    why = ""
    contract = plan.contract
    feature = next(
        (
            p
            for p in plan.path.pieces
            if p.kind in (PieceKind.BEND, PieceKind.TEE) and p.start_m > belief_m + 1e-3
        ),
        None,
    )
    if feature is not None:
        slack = localiser.uncertainty_m(feature.start_m - localiser.last_fix_m)
        limit = feature.start_m - contract.min_margin_m - slack
        what = f"{feature.segment!r} may be {slack:.2f} m nearer than the map has it"
    else:
        end = plan.path.length_m
        slack = localiser.uncertainty_m(end - localiser.last_fix_m)
        limit = end - contract.end_margin_m - slack
        what = f"the end of the pipe may be {slack:.2f} m nearer than the map has it"
    if distance > limit - belief_m + 1e-3:
        distance = limit - belief_m
        why = f"shortened: {what}"
    return max(distance, 0.0), why


def _stopped_blocked(node: Any, pab: PlannedPab | None) -> bool:
    """A forward straight leg whose drive stopped early, blocked by the pipe."""
    if pab is None or pab.pab != "straight" or pab.end_m <= pab.start_m:
        return False
    return any(getattr(n, "sensed", None) == "blocked" for n in node.iterate())


def _cut(node: Any, plan: MissionPlan, legs: list[Leg]) -> ShortLeg | None:
    """The blocked leg ``node`` as cut short of its distance, if it was."""
    blocked = (n for n in node.iterate() if getattr(n, "sensed", None) == "blocked")
    travelled = getattr(next(blocked, None), "sensed_after_m", None)
    leg = next((g for g in reversed(legs) if g.label == node.name), None)
    if travelled is None or leg is None:
        return None
    return short_leg(plan, node.name, abs(leg.driven_m), travelled)


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
    belief_m: float | None = None,
    map_tolerance: float = MAP_FRACTION,
    observe: Observer | None = None,
    since_fix_m: float = 0.0,
    fixed_before: str | None = None,
    count_from_open: bool = False,
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
        belief_m: Where the robot is believed to be at the start (default: the plan's
            start; a re-planned mission starts from the belief it stopped with).
        map_tolerance: How far the map's lengths may be off, as a fraction of the
            distance from the last fix (default 10 %; 0 for a map known to be exact):
            features are searched within it, and forward legs stop short by it.
        observe: Called with the runner, before it runs, and a function giving the
            localiser's figures of the moment (belief, truth, last fix) as numbers:
            attach more hooks here (a live Foxglove view, say).
        since_fix_m: Metres driven since the last feature fix before this mission (a
            navigation's step goes on from the steps before it): the features'
            search windows start that wide.
        fixed_before: The feature (segment id) that last fix was on: it and the
            features before it are placed by that fix, so a block near one of them
            behind the robot is not taken for it.
        count_from_open: Count the link's and the simulator's figures from the moment
            the link opened, as a tree run does (the first run on a new connection): a
            slide as the robot was put in a steep pipe, before its first clamp held, is
            then in the result's counters and its ``why``.

    Returns:
        The result; a failed mission is a result, not an exception.

    Raises:
        ValidationFailed: the PAB trees do not load with the plan's parameters.
        ConfigurationError: a PAB tree is missing.
    """
    from pirate_bt.treefile import load_tree

    spec = mission_tree_spec(plan, trees_dir, robot.motion.nominal_speed, robot.motion.steer_angle)
    loaded = load_tree(spec, robot=robot, clock=clock, supervisor=supervisor)
    limit = max_time_s or estimate_time_s(plan, robot.motion.nominal_speed)
    reason_box = ["mission ended without success"]
    runner = Runner.supervised(
        loaded,
        supervisor,
        clock=clock,
        end_reason=lambda: reason_box[0],
        tick_supervisor=False,  # ticked in before()
        period_s=period_s,
        max_time_s=limit,
        realtime=realtime,
    )
    coverage = attach_coverage(runner, loaded.name)
    localiser = Localiser(plan, robot, truth=truth, tees_felt=True, map_fraction=map_tolerance)
    slopes = SlopeWatch(plan.path, robot.behind_front_tip_m()[robot.rotational_module().name])
    if belief_m is not None:
        localiser.belief_m = localiser.last_fix_m = belief_m
    localiser.since_fix_m = max(since_fix_m, 0.0)
    localiser.fixed_before = fixed_before
    pabs = {pab.label(i): pab for i, pab in enumerate(plan.pabs, start=1)}
    legs: list[Leg] = []
    start_s = clock.now()
    timeline: list[TimelineEntry] = []
    samples: list[Sample] = []
    route_node = runner.tree.root.children[-1]
    current: list[str | None] = [None]
    running: list[Any] = [None]  # the PAB node of the leg running
    blackboard = py_trees.blackboard.Client(name="localiser")
    blackboard.register_key(MAP_OK_KEY, access=py_trees.common.Access.WRITE)
    blackboard.register_key(LEG_DISTANCE_KEY, access=py_trees.common.Access.WRITE)
    blackboard.set(LEG_DISTANCE_KEY, None)

    def start_leg(name: str) -> None:
        pab = pabs.get(name)
        if pab is None or pab.pab != "straight":
            blackboard.set(LEG_DISTANCE_KEY, None)  # a stale distance must never be driven
            return
        metres, why = leg_distance_m(plan, pab, localiser.belief_m, localiser)
        legs.append(Leg(name, pab.end_m - pab.start_m, metres, localiser.belief_m, why))
        blackboard.set(LEG_DISTANCE_KEY, abs(metres))

    def before(_info: Any) -> None:
        supervisor.tick()

    found_s: list[float | None] = [None]  # when the localiser found its mismatch

    def check_blocked(time_s: float, cut: ShortLeg | None) -> None:
        """A leg ended blocked: a disagreement, or the end of the line (said when that
        is short of the map's end)."""
        localiser.blocked(time_s, cut)
        if localiser.mismatch is None and cut is not None and cut.to_end:
            args = (localiser.fixes, localiser.since_fix_m, plan.path, localiser.belief_m)
            note = ended_short(*args, plan.contract.end_margin_m)
            if note is not None:
                slopes.notes.append(note)

    def noticed() -> None:
        if localiser.mismatch is not None and found_s[0] is None:
            found_s[0] = clock.now()

    def after(_info: Any) -> None:
        state = supervisor.state()
        localiser.update(state)
        slopes.update(state, localiser.belief_m)
        noticed()
        now = clock.now() - start_s
        if state is not None and (not samples or samples[-1].time_s != now):
            samples.append(Sample(round(now, 4), localiser.belief_m, localiser.truth_m))
        child = getattr(route_node, "current_child", None)
        name = child.name if child is not None and child.status.name == "RUNNING" else None
        if name is not None and name != current[0]:
            ended = running[0]
            if ended is not None and _stopped_blocked(ended, pabs.get(ended.name)):
                check_blocked(state.stamp_s if state is not None else now, _cut(ended, plan, legs))
            timeline.append(TimelineEntry(now, name, localiser.belief_m, localiser.truth_m))
            start_leg(name)
            running[0] = child
        current[0] = name or current[0]
        if localiser.mismatch is not None and blackboard.get(MAP_OK_KEY):
            reason_box[0] = localiser.mismatch
            blackboard.set(MAP_OK_KEY, False)

    runner.add_pre_tick(before)
    runner.add_post_tick(after)
    tally = VerdictTally(supervisor, from_open=count_from_open)

    def first_mismatch() -> str | None:
        """The localiser's mismatch, unless the robot was in its safe state before it
        was found: a robot sliding back down a riser after its clamp board went swings
        its IMU, and the disagreement the localiser finds in the run's last ticks is
        the slide's, not the first cause (the stale readings that stopped the run)."""
        first = tally.first_safe_state
        if found_s[0] is not None and first is not None and first.time_s < found_s[0]:
            return None
        return localiser.mismatch

    def why(run: RunResult) -> str:
        first = tally.first_safe_state
        return first_mismatch() or explain_run(run, runner.tree.root, first)[0]

    recorder = None
    if trace_path is not None:
        from pirate_bt.trace import attach_trace, supervised_extras

        extras = supervised_extras(supervisor, counters=counters, more=localiser.values)
        trace_path.parent.mkdir(parents=True, exist_ok=True)
        recorder = attach_trace(
            runner,
            trace_path,
            extras=extras,
            why=why,
            robot=robot,
            scenario=scenario,
            seed=seed,
            meta={"route": plan.route.to_json(), "plan": plan.describe()},
        )
    if live:
        from pirate_bt.trace import attach_live_view

        attach_live_view(runner, live_stream)
    if observe is not None:
        from pirate_bt.trace.attach import call_observer

        # one that raises leaves no trace of a run that never started
        call_observer(observe, runner, localiser.values, recorder, trace_path)
    try:
        result = runner.run()
        last = running[0]
        if result.succeeded and last is not None and _stopped_blocked(last, pabs.get(last.name)):
            # The last leg ended blocked: checked as a leg's end is when the next one
            # starts (a pipe that ends where the map has it go on is no success).
            state = supervisor.state()
            time_s = state.stamp_s if state is not None else clock.now() - start_s
            check_blocked(time_s, _cut(last, plan, legs))
            if localiser.mismatch is not None:
                supervisor.safe_state(localiser.mismatch)
                result = replace(
                    result,
                    outcome="failure",
                    reason=StopReason.FAILURE,
                    message=localiser.mismatch,
                    safe_state_called=True,
                )
    finally:
        tally.detach()
    if result.error is None and (link_error := link_cause(result, supervisor)) is not None:
        result = replace(result, error=link_error)  # exits as a link error (code 3)
    localiser.update(supervisor.state())
    noticed()
    mismatch = first_mismatch()
    end = clock.now() - start_s
    outcomes = pab_outcomes(
        route_node,
        {label: pab.pab for label, pab in pabs.items()},
        [(e.label, e.time_s) for e in timeline],
        end,
        run=result,
        safe=tally.first_safe_state,
        stopped_by=mismatch,
    )
    reason, failing, map_named = _why(
        result, runner.tree.root, outcomes, plan, localiser, tally, mismatch
    )
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
        mismatch=mismatch or (reason if map_named else None),
        start_s=start_s,
        disagreement=localiser.disagreement,
        legs=legs,
        pabs=outcomes,
        why=reason,
        failing_node=failing,
        counters=tally.counters(overruns=result.overrun_count),
        wall_s=result.wall_time_s,
        safe_state=bool(supervisor.in_safe_state),
        coverage=coverage.coverage(),
        map_notes=list(slopes.notes),
    )


def _why(
    run: RunResult,
    root: Any,
    outcomes: list[PabOutcome],
    plan: MissionPlan,
    localiser: Localiser,
    tally: VerdictTally,
    mismatch: str | None,
) -> tuple[str, str | None, bool]:
    """The mission's first cause, the node it happened at (see :mod:`.outcome`), and
    whether a PAB's failure was named a map disagreement."""
    if run.succeeded:
        return f"mission completed: {counted(len(outcomes), 'PAB')}, {run.message}", None, False
    stopped = next((p for p in outcomes if p.outcome in ("failure", "stopped")), None)
    # the PAB's path from the root, as a node's inside it is (not its bare label)
    where = f"{route_path(root.children[-1])}/{stopped.label}" if stopped is not None else None
    if mismatch is not None:
        return mismatch + _unfelt_but_passed(outcomes, plan, localiser), where, False
    if stopped is not None and stopped.outcome == "failure":
        planned = {pab.label(i): pab for i, pab in enumerate(plan.pabs, start=1)}
        named = map_cause(stopped, planned.get(stopped.label), localiser.belief_m)
        return named or stopped.why, stopped.failing_node or where, named is not None
    return (*explain_run(run, root, tally.first_safe_state), False)


def _unfelt_but_passed(outcomes: list[PabOutcome], plan: MissionPlan, localiser: Localiser) -> str:
    """A turn the IMU never felt, which the bend PAB through it passed: the IMU is the
    suspect, not the map. The bend PAB completes only where its steered front was held
    at a turn and its rear then drove through one (a cap, or a bend the other way,
    fails it), so a stuck IMU pitch read as *the map has 'foot' ..., but no turn was
    felt*, a map's error, until the twenty-second session."""
    found = localiser.disagreement
    if found is None or found.sensed is not None or found.feature is None:
        return ""
    if not found.evidence.startswith("the IMU swung"):
        return ""
    done = {p.label for p in outcomes if p.outcome == "success"}
    for index, pab in enumerate(plan.pabs, start=1):
        if pab.pab == "bend" and pab.feature == found.feature and pab.label(index) in done:
            swing = found.evidence.split(",")[0].removeprefix("the IMU ")
            return (
                f"; yet the bend PAB through {found.feature!r} completed before it, so the"
                f" IMU, which {swing}, may be stuck"
            )
    return ""


def truth_on_map(plan: MissionPlan, truth_path: Any, truth_m: float) -> float:
    """Where a truth position lies on the map, counted from the same feature.

    The simulator's front tip (metres along the true pipe) is put on the map at the
    same distance past the start of the same segment (the same ids in both), so
    after a fix at a feature the belief and this agree when the localiser is right,
    whatever the map got wrong about the pipe before that feature. A segment the map
    does not have (a tee nobody drew) counts from the last segment both have.

    Args:
        plan: The plan (its path is the map's).
        truth_path: The simulator's path (the pipe really taken).
        truth_m: The front tip along ``truth_path``.
    """
    pieces = truth_path.pieces
    index = truth_path.index_at(truth_m)
    on_map = {p.segment: p for p in plan.path.pieces}
    for k in range(index, -1, -1):
        piece = pieces[k]
        mapped = on_map.get(piece.segment)
        if mapped is not None and mapped.kind is piece.kind:
            offset = truth_m - piece.start_m
            if piece.length_m > 0 and piece.angle_rad > 0:
                offset *= mapped.length_m / piece.length_m
            return float(mapped.start_m + offset)
    return truth_m


def truth_of(plan: MissionPlan, sim: Any) -> Callable[[], float | None]:
    """The simulator's front tip, on ``plan``'s map (:func:`truth_on_map`)."""
    return lambda: truth_on_map(plan, sim.model.path, sim.model.s_m)
