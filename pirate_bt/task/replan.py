"""Going on after a stop: re-plan where the route still has one clear meaning, or return.

:func:`carry_on` runs after :func:`~pirate_bt.task.mission.run_mission` when the
mission stopped: :func:`replan_after` decides whether the route still has one
clear meaning (a T-joint the map does not have, felt during a forward leg), and
the rest of the route runs on a corrected map from the belief. ``return_to_start``
plans the way back after a stop (:func:`~pirate_bt.task.planner.plan_return`).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from pirate_bt.clock import Clock
from pirate_bt.robot.description import RobotDescription
from pirate_bt.task.localise import MAP_FRACTION
from pirate_bt.task.mission import MissionResult, Observer, run_mission, truth_of
from pirate_bt.task.outcome import FOUND_TEE, counted
from pirate_bt.task.plan import MissionPlan

__all__ = ["carry_on", "joined", "replan_after", "return_to_start"]

_MAX_REPLANS = 3


def carry_on(
    result: MissionResult,
    robot: RobotDescription,
    supervisor: Any,
    clock: Clock,
    *,
    truth_for: Callable[[MissionPlan], Callable[[], float | None]] | None = None,
    counters: Callable[[], Any] | None = None,
    period_s: float = 0.05,
    map_tolerance: float = MAP_FRACTION,
    observe: Observer | None = None,
    max_time_s: float | None = None,
    started_s: float | None = None,
) -> MissionResult:
    """After a stop, re-plan and go on where the route still has one clear meaning.

    :func:`replan_after` decides; each re-planned rest runs from the belief the
    robot stopped with, after the safe state is left. Returns the joined result
    (``result.replans`` says what was done), or ``result`` itself.

    ``max_time_s`` (from ``started_s``, clock time) bounds the whole mission: a rest
    runs in the time left, and none starts once it is spent. Without it each rest has
    its own estimate, as the first run had.
    """
    for _ in range(_MAX_REPLANS):
        again = replan_after(result)
        if again is None:
            break
        rest, note = again
        left: float | None = None
        if max_time_s is not None:
            since = clock.now() - (started_s if started_s is not None else clock.now())
            left = max_time_s - since
            if left < period_s:
                result.replans.append(
                    f"not re-planned: the mission's time limit ({max_time_s:g} s) is spent"
                )
                break
        supervisor.resume()  # the route still has one clear meaning: go on
        more = run_mission(
            rest,
            robot,
            supervisor,
            clock,
            truth=truth_for(rest) if truth_for is not None else None,
            counters=counters,
            period_s=period_s,
            belief_m=result.belief_m,
            map_tolerance=map_tolerance,
            observe=observe,
            max_time_s=left,
        )
        result = joined(result, more, note)
    return result


def _beyond_reach(plan: MissionPlan, feature: str | None, at_m: float, reach_m: float) -> bool:
    """Whether the map's next tee (``feature``, named by an opening's disagreement as
    the one expected) is further than the matcher's reach from the opening felt at
    ``at_m``: then the opening is not that tee, and a tee the map does not have. (Such
    an opening on a line with a tee further on stopped the mission: the lab's route,
    with a tee built 1.5 m into run-c, stopped there for tee-2, 10.6 m on.)"""
    pieces = [p for p in plan.path.pieces if p.segment == feature and p.kind.value == "tee"]
    if not pieces:
        return False
    opening_m = (pieces[0].start_m + pieces[0].end_m) / 2
    return abs(opening_m - at_m) > reach_m + plan.robot_length_m


def _mapped_tee_near(
    result: MissionResult, at_m: float, reach_m: float
) -> tuple[str, float] | None:
    """A tee of the route's map not yet fixed on whose opening is within the matcher's
    reach plus the robot's length of an opening felt at ``at_m``, as ``(id, opening_m)``:
    that tee, nearer (or further) than drawn, not one the map lacks. A tee the route turns
    into is one too: the localiser expects it as a turn, so its disagreement names none
    (*no T-joint within ...*), and the mission re-planned through it straight, then
    searched for it where it was drawn (a straight built half as long as drawn: the
    robot crossed the tee it was to turn into and was blocked at the line's end)."""
    plan = result.plan
    fixed = {fix.feature for fix in result.fixes}
    for piece in plan.path.pieces:
        if piece.kind.value != "tee" or piece.segment in fixed:
            continue
        opening_m = (piece.start_m + piece.end_m) / 2
        if abs(opening_m - at_m) <= reach_m + plan.robot_length_m:
            return piece.segment, opening_m
    return None


def replan_after(result: MissionResult) -> tuple[MissionPlan, str] | None:
    """Where a stop still leaves the route one clear meaning, the plan for the rest.

    One case has one: a T-joint the map does not have, felt by the front half
    during a forward leg (``forward``, ``inspect``, an approach, ``go to``). The
    route meant to go on along this line, so the robot passes the tee straight
    through. The map is corrected (a tee where the opening was felt, the line's
    length kept) and the rest of the route is planned on it from the belief: the
    T-joint first, then what was left of the interrupted command, then the rest.

    Returns:
        ``(plan, note for the report)``, or ``None`` when the stop stands.
    """
    from pirate_bt.errors import ConfigurationError, LocatedError
    from pirate_bt.pipes import Network
    from pirate_bt.pipes.asbuilt import insert_tee
    from pirate_bt.robot.description import Half
    from pirate_bt.robot.loader import load_robot
    from pirate_bt.task.planner import plan_route
    from pirate_bt.task.route import Route, RouteStep, StepKind

    d = result.disagreement
    if d is None or d.sensed_at_m is None or d.sensed_by is None:
        return None
    plan = result.plan
    if d.expected is not None and not _beyond_reach(plan, d.feature, d.sensed_at_m, d.window_m):
        return None  # the map's own tee, found nearer than drawn? no clear meaning
    near = _mapped_tee_near(result, d.sensed_at_m, d.window_m)
    if near is not None:  # the same, for a tee the route turns into
        tee_id, opening_m = near
        gap_m = opening_m - d.sensed_at_m
        where = f"{gap_m:.2f} m further on" if gap_m >= 0 else f"{-gap_m:.2f} m behind it"
        shorter = "shorter" if gap_m >= 0 else "longer"
        result.replans.append(
            f"not re-planned: the opening felt at {d.sensed_at_m:.2f} m (believed) may be the"
            f" map's T-joint {tee_id!r}, drawn {where} (at {opening_m:.2f} m): is the pipe"
            f" before it {shorter} than drawn? A T-joint the map does not have, so near"
            " it, has no clear meaning"
        )
        return None
    robot = load_robot()
    if d.sensed_by not in {m.name for m in robot.bend_modules(Half.FRONT)}:
        return None
    labels = {pab.label(i): pab for i, pab in enumerate(plan.pabs, start=1)}
    running = [e.label for e in result.timeline if e.label in labels]
    if not running or labels[running[-1]].pab != "straight":
        return None
    leg = labels[running[-1]]
    if leg.end_m <= leg.start_m:
        return None  # backwards: no clear meaning
    piece = plan.path.piece_at(d.sensed_at_m)
    if piece.kind.value != "straight":
        return None
    tee_id = f"{FOUND_TEE}{len(result.replans) + 1}"
    tee_m = 3.0 * piece.diameter_start_m
    try:
        spec = insert_tee(
            plan.network.spec,
            piece.segment,
            max(d.sensed_at_m - piece.start_m - tee_m / 2, 1e-3),
            "up",
            tee_id=tee_id,
            name=plan.network.name,
            keep_length=True,
        )
    except ConfigurationError:
        return None
    corrected = Network(spec, plan.network.source)
    tee = next(p for p in corrected.main_path().pieces if p.segment == tee_id)
    # plan as if the robot stood at the tee (it senses the opening where it is)
    at_m = min(result.belief_m, tee.start_m - plan.contract.approach_m)
    tee_step = RouteStep(StepKind.TEE, leg.step.location, leg.step.text, direction="straight")
    steps: list[RouteStep] = [tee_step]
    if leg.absolute:
        steps.append(leg.step)  # to a place: ask for it again from beyond the tee
    elif leg.step.distance_m is not None:
        started = next(x.belief_m for x in result.legs if x.label == running[-1])
        target = started + (leg.end_m - leg.start_m)
        try:
            first = plan_route(
                Route(plan.route.name, plan.route.source, (tee_step,), plan.route.network),
                corrected,
                robot,
                plan.contract,
                start_m=at_m,
            )
        except LocatedError:
            # the found tee cannot be passed as planned (too near the next feature): no
            # clear meaning, the stop stands and is the result
            return None
        left = target - first.end_m
        if left > 0.01:
            steps.append(
                RouteStep(
                    leg.step.kind,
                    leg.step.location,
                    f"{leg.step.text} (the rest, {left:.2f} m)",
                    distance_m=round(left, 3),
                    slowly=leg.step.slowly,
                )
            )
    steps += [s for s in plan.route.steps if s.line > leg.step.line]
    route = Route(plan.route.name, plan.route.source, tuple(steps), plan.route.network)
    try:
        new_plan = plan_route(route, corrected, robot, plan.contract, start_m=at_m)
    except LocatedError:
        return None
    note = (
        f"a T-joint the map does not have was felt at {d.sensed_at_m:.2f} m (by"
        f" {d.sensed_by}) during '{leg.step.text}'; the route goes on along this line, so"
        f" the map was corrected ({tee_id!r}) and the rest re-planned from"
        f" {result.belief_m:.2f} m: through the tee, then {len(steps) - 1} more command(s)"
    )
    return new_plan, note


def joined(first: MissionResult, then: MissionResult, note: str) -> MissionResult:
    """One result for a mission that re-planned once: ``then`` carried on from ``first``."""
    from dataclasses import replace

    offset = then.start_s - first.start_s
    replans = (
        [*first.replans, f"{note} ({first.disagreement.describe()})"]
        if first.disagreement is not None
        else [*first.replans, note]
    )
    pabs = [
        *(p for p in first.pabs if p.outcome != "not run"),
        *(
            replace(
                p,
                start_s=None if p.start_s is None else p.start_s + offset,
                end_s=None if p.end_s is None else p.end_s + offset,
            )
            for p in then.pabs
        ),
    ]
    why = then.why
    if then.succeeded:
        # The whole mission's account, not the re-planned part's alone ("2 PABs").
        times = "once" if len(replans) == 1 else f"{len(replans)} times"
        ran = sum(p.outcome != "not run" for p in pabs)
        why = f"mission completed: {counted(ran, 'PAB')}, re-planned {times}"
    return replace(
        then,
        why=why,
        reason=why if then.succeeded else then.reason,
        fixes=[*first.fixes, *then.fixes],
        legs=[*first.legs, *then.legs],
        timeline=[
            *first.timeline[:-1],
            *(replace(e, time_s=e.time_s + offset) for e in then.timeline),
        ],
        samples=[*first.samples, *(replace(x, time_s=x.time_s + offset) for x in then.samples)],
        odometry_m=first.odometry_m + then.odometry_m,
        start_s=first.start_s,
        pabs=pabs,
        counters=first.counters + then.counters,
        wall_s=first.wall_s + then.wall_s,
        replans=replans,
    )


def return_to_start(
    result: MissionResult,
    robot: RobotDescription,
    supervisor: Any,
    clock: Clock,
    sim: Any,
    observe: Observer | None = None,
) -> MissionResult | None:
    from pirate_bt.errors import LocatedError
    from pirate_bt.task.planner import plan_return

    try:
        back = plan_return(result.plan, result.belief_m, [f.feature for f in result.fixes])
    except LocatedError as exc:
        result.replans.append(f"no way back planned: {exc.message}")
        return None
    if not back.pabs:  # stopped before it moved off the start: nothing to drive
        result.replans.append("no way back to drive: the robot is still at the start")
        return None
    supervisor.resume()  # the operator's decision: leave the safe state and come back
    result.replans.append(f"returning to the start: {back.distance_m:.2f} m back")
    returned = run_mission(
        back,
        robot,
        supervisor,
        clock,
        truth=truth_of(back, sim),
        counters=sim.counters,
        observe=observe,
    )
    # the mission's own fields stay the mission's (where it stopped, and why); how the
    # way back went is said here too, so a report and the command line show it
    where = f"believed at {returned.belief_m:.2f} m" + (
        f", truly {returned.truth_m:.2f} m" if returned.truth_m is not None else ""
    )
    if returned.succeeded:
        result.replans.append(f"back at the start ({where})")
    else:
        result.replans.append(f"the way back failed: {returned.why} ({where})")
    return returned
