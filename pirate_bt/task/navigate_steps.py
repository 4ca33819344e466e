"""How one navigation step runs: planned on the map as a one-step mission, or blind.

Split out of :mod:`pirate_bt.task.navigate` (the loop). :func:`run_mapped` runs a
step planned on the map as a one-step mission (the localiser, its fixes, map
disagreements); :func:`run_blind` runs the step's PAB tree with the step's own
parameters and keeps the belief by odometry. Both return a :class:`StepRun`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import py_trees

from pirate_bt.clock import Clock
from pirate_bt.pipes import PieceKind
from pirate_bt.robot.description import RobotDescription
from pirate_bt.robot.state import wheel_fresh_window_s
from pirate_bt.runner import Runner
from pirate_bt.runner import RunResult as TreeRun
from pirate_bt.safety.checks import off_wall_rad
from pirate_bt.safety.tally import VerdictTally
from pirate_bt.task.mission import MissionResult, run_mission
from pirate_bt.task.navigation import CheckedStep, Felt, OffWall
from pirate_bt.task.outcome import END_OF_RUN, PabOutcome, explain_run, link_cause
from pirate_bt.task.plan import PAB_FILES, MissionPlan, direction_name
from pirate_bt.task.tree import steer_param

__all__ = ["StepRun", "plan_mapped", "run_blind", "run_mapped"]

_PROBES = {"probe-turn": "/probe_roll", "probe-tee": "/probe_side"}
"""The probe PABs (a tree with no parameters) and the blackboard key each answers on."""
_BLIND_FILES = {"bend-back": "bend-back.yaml", "t-joint-back": "t-joint-back.yaml"}
"""The backward PABs' trees (a map does not plan them yet)."""
_SIDES = ("left", "right", "up", "down")
_PROBE_DIRECTIONS = {"0": "up", "180": "down", "90": "right", "-90": "left"}
"""``probe-turn``'s ``probe_roll`` (degrees, as trees/probe-turn.yaml writes it) -> direction."""


@dataclass
class StepRun:
    """How one navigation step ran."""

    succeeded: bool
    why: str
    failing_node: str | None
    pabs: list[PabOutcome]
    belief_m: float
    felt: list[Felt]
    disagreement: bool = False
    error: BaseException | None = None
    mission: MissionResult | None = None
    truth_m: float | None = None
    ticks: int = 0
    stamp_s: float = math.nan
    """Blind steps: the state stamp the odometry ended on."""
    off_wall: bool = False
    """Blind steps: a bend joint swung off the wall during the step (over an opening)."""
    openings: tuple[OffWall, ...] = ()
    """Blind steps: each time a bend joint swung off the wall, oldest first."""


def _felt_on_map(mission: MissionResult) -> list[Felt]:
    pieces = {p.segment: p for p in mission.plan.path.pieces}
    out: list[Felt] = []
    for fix in mission.fixes:
        piece = pieces.get(fix.feature)
        kind = "tee" if piece is not None and piece.kind is PieceKind.TEE else "bend"
        direction = None
        if piece is not None and kind == "bend":
            direction = direction_name(piece.roll_rad)
        elif piece is not None:
            way = mission.plan.choices.get(fix.feature, "straight")
            direction = "straight" if way == "straight" else direction_name(piece.roll_rad)
        out.append(Felt(kind, fix.after_m, fix.feature, direction, fix.how))
    return out


def plan_mapped(
    planner: Any,
    line: str,
    index: int,
    belief_m: float,
    roll_rad: float | None,
    source: str | None,
    robot_length_m: float,
) -> MissionPlan:
    """A step planned on the map from the belief (:meth:`~pirate_bt.task.step_planner.
    StepPlanner.plan`); a T-joint step refused there because the robot's front tip is
    past the start of a tee its body straddles (the leg before stopped over an opening
    nearer than drawn: a fix put the belief past the tee's start) is planned from the
    tee's approach point, as a mission plans its re-planned rest: the T-joint PAB
    crosses the tee from where the robot stands. It was refused as the navigator's
    invalid step (*'at the T-joint go straight' does not fit the network: there is no
    T-joint ahead on 'b'*), where a mission on the same map and pipe went on.

    A forward leg from across such a tee is refused, naming it: the straight PAB stops
    at once over an opening (for a T-joint PAB after it), and the step was a success
    that moved nothing.

    Raises:
        LocatedError: the step does not fit the map (from the belief, as before), or
            is a forward leg from across a tee.
        ValidationFailed: the line does not parse.
    """
    from pirate_bt.errors import LocatedError

    walker = planner._walker  # the way taken so far, on which the steps are planned
    straddled = [
        p
        for p in walker.path.pieces
        if p.kind is PieceKind.TEE
        and p.segment not in walker.choices
        and p.start_m < belief_m < p.end_m + robot_length_m
    ]
    try:
        plan: MissionPlan = planner.plan(line, index, belief_m, roll_rad=roll_rad, source=source)
    except LocatedError as exc:
        refused = exc
    else:
        forward = [p for p in plan.pabs if p.pab == "straight" and p.end_m > p.start_m]
        if straddled and forward and forward[0] is plan.pabs[0]:
            # a leg from over the opening stops at once (the straight PAB's shortcut for
            # a T-joint PAB after it): it was a success that moved nothing
            tee = straddled[0]
            raise LocatedError(
                f"{line!r} does not fit the network: the robot is across the T-joint"
                f" {tee.segment!r} ({tee.start_m:.2f}-{tee.end_m:.2f} m), over its opening,"
                " where a straight stops at once; write 'at the T-joint go straight' (or"
                " into the branch) to cross it",
                plan.route.steps[0].location,
            )
        return plan
    if not line.startswith("at the T-joint") or not straddled:
        raise refused
    at_m = straddled[0].start_m - planner.contract.approach_m
    try:
        return planner.plan(line, index, at_m, roll_rad=roll_rad, source=source)  # type: ignore[no-any-return]
    except LocatedError:
        raise refused from None


def run_mapped(
    plan: MissionPlan,
    robot: RobotDescription,
    supervisor: Any,
    clock: Clock,
    *,
    truth_for: Callable[[MissionPlan], Callable[[], float | None]] | None,
    counters: Callable[[], Any] | None,
    trace_path: Path | None,
    period_s: float,
    max_time_s: float,
    belief_m: float,
    map_tolerance: float,
    since_fix_m: float = 0.0,
    fixed_before: str | None = None,
) -> StepRun:
    if not plan.pabs:  # nothing to drive (already there)
        return StepRun(True, "", None, [], belief_m, [])
    from pirate_bt.task.mission import estimate_time_s

    limit = min(max_time_s, estimate_time_s(plan, robot.motion.nominal_speed))
    started_s = clock.now()
    mission = run_mission(
        plan,
        robot,
        supervisor,
        clock,
        truth=truth_for(plan) if truth_for is not None else None,
        counters=counters,
        trace_path=trace_path,
        period_s=period_s,
        max_time_s=limit,
        belief_m=belief_m,
        map_tolerance=map_tolerance,
        since_fix_m=since_fix_m,
        fixed_before=fixed_before,
    )
    if not mission.succeeded:
        # a tee the map does not have, felt on a forward leg: the step goes on along
        # this line through it, as a mission does (one clear meaning), the map corrected
        from pirate_bt.task.replan import carry_on

        mission = carry_on(
            mission,
            robot,
            supervisor,
            clock,
            truth_for=truth_for,
            counters=counters,
            period_s=period_s,
            map_tolerance=map_tolerance,
            max_time_s=max_time_s,  # the navigation's time left: the rest has its own estimate
            started_s=started_s,
        )
    return StepRun(
        mission.succeeded,
        mission.why,
        mission.failing_node,
        list(mission.pabs),
        mission.belief_m,
        _felt_on_map(mission),
        disagreement=mission.mismatch is not None,
        error=mission.error,
        mission=mission,
        truth_m=mission.truth_m,
        ticks=mission.ticks,
    )


def _blind_node(checked: CheckedStep, robot: RobotDescription) -> dict[str, Any]:
    """The step's PAB as a tree node (a subtree reference to the bundled PAB tree)."""
    from pirate_bt.resources import data_dir

    pab = checked.step.pab
    if pab == "wait":
        return {"type": "wait", "name": "wait", "duration": checked.time_s}
    params: dict[str, Any]
    if pab == "straight":
        speed = robot.motion.nominal_speed * (0.5 if checked.slow else 1.0)
        params = {
            "distance": abs(checked.distance_m),
            "velocity": speed if checked.distance_m > 0 else -speed,
            "stop_at_feature": checked.stop_at_feature and checked.distance_m > 0,
            "stop_at_change": checked.stop_at_change,
        }
    elif pab in ("bend", "bend-back"):
        params = {"roll": checked.roll_rad}
    else:
        params = {"direction": checked.direction}
    if pab in _PROBES:
        ref = data_dir("trees") / f"{pab}.yaml"
        steer = steer_param(ref, robot.motion.steer_angle)
        return {
            "type": "subtree",
            "name": pab,
            "ref": str(ref),
            **({"params": steer} if steer else {}),
        }
    ref = data_dir("trees") / _BLIND_FILES.get(pab, PAB_FILES.get(pab, ""))
    params.update(steer_param(ref, robot.motion.steer_angle))
    return {"type": "subtree", "name": pab, "ref": str(ref.resolve()), "params": params}


def run_blind(
    checked: CheckedStep,
    index: int,
    robot: RobotDescription,
    supervisor: Any,
    clock: Clock,
    *,
    counters: Callable[[], Any] | None,
    trace_path: Path | None,
    period_s: float,
    max_time_s: float,
    belief_m: float,
    scenario: str | None,
    seed: int | None,
    stamp_s: float = math.nan,
) -> StepRun:
    """Run one step's PAB tree with its own parameters; the belief by odometry.

    ``stamp_s`` is the state stamp the previous blind step's odometry ended on, so the
    wheels' motion between the two steps' ticks (a coast) is counted, not lost.
    """
    from pirate_bt.treefile import load_tree

    step = checked.step
    label = f"{index:02d} {step.pab}"
    spec = {"name": f"step {index}", "root": {**_blind_node(checked, robot), "name": label}}
    loaded = load_tree(spec, robot=robot, clock=clock, supervisor=supervisor)
    limit = max(max_time_s, period_s)
    runner = Runner.supervised(
        loaded,
        supervisor,
        clock=clock,
        # keep the cause a PAB or the supervisor gave first; the generic end is no
        # cause of its own (a step cut by the time budget is named so)
        end_reason=lambda: supervisor.safe_state_reason or END_OF_RUN,
        period_s=period_s,
        max_time_s=limit,
    )
    odometry = [belief_m, stamp_s]  # belief, last stamp
    window_s = wheel_fresh_window_s(robot)  # odometry counts fresh, agreeing wheels
    # past every wall-contact angle: a joint over an opening (as the drive tells one)
    beyond = off_wall_rad(robot)
    joints = [m.name for m in robot.all_bend_modules()]
    off_wall = [False]
    behind = robot.behind_front_tip_m()
    away: dict[str, int] = {}  # the joints off the wall now -> their episode
    episodes: list[list[Any]] = []  # [joint, belief off, belief back] as OffWall has them

    def after(_info: Any) -> None:
        state = supervisor.state()
        if state is None:
            return
        if odometry[1] == odometry[1]:  # not nan: a previous stamp
            speed = state.mean_drive_velocity_mps(state.stamp_s - window_s)
            odometry[0] += speed * max(0.0, state.stamp_s - odometry[1])
        odometry[1] = state.stamp_s
        angles = state.joint_angle_rad
        for name in joints:
            if abs(angles.get(name, 0.0)) > beyond:
                if name not in away:
                    away[name] = len(episodes)
                    episodes.append([name, odometry[0], None])
            elif name in away:
                episodes[away.pop(name)][2] = odometry[0]
        off_wall[0] = off_wall[0] or bool(away)

    runner.add_post_tick(after)
    tally = VerdictTally(supervisor)
    if trace_path is not None:
        from pirate_bt.trace import attach_trace, supervised_extras

        attach_trace(
            runner,
            trace_path,
            extras=supervised_extras(supervisor, counters=counters),
            robot=robot,
            scenario=scenario,
            seed=seed,
            meta={"navigation_step": index, "step": step.to_json()},
        )
    started = clock.now()
    if step.pab in _PROBES:  # the tree writes it; never read a previous probe's
        py_trees.blackboard.Blackboard.storage.pop(_PROBES[step.pab], None)
    try:
        run: TreeRun = runner.run()
    finally:
        tally.detach()
    why, failing = ("", None)
    if not run.succeeded:
        why, failing = explain_run(run, runner.tree.root, tally.first_safe_state)
    moved = odometry[0] - belief_m
    felt: list[Felt] = []
    if run.succeeded and step.pab == "bend":
        felt.append(Felt("bend", odometry[0], direction=checked.direction, how="pab"))
    elif run.succeeded and step.pab == "t-joint":
        felt.append(Felt("tee", odometry[0], direction=checked.direction, how="pab"))
    elif run.succeeded and step.pab in _BLIND_FILES:
        kind = "bend" if step.pab == "bend-back" else "tee"
        felt.append(Felt(kind, odometry[0], direction=checked.direction, how="back"))
    elif run.succeeded and step.pab == "probe-tee":
        side = str(py_trees.blackboard.Blackboard.storage.get("/probe_side", ""))
        if side in _SIDES:
            felt.append(Felt("tee", odometry[0], direction=side, how="probe"))
        elif side == "none":
            felt.append(Felt("opening", odometry[0], how="probe"))
    elif run.succeeded and step.pab == "probe-turn":
        found = str(py_trees.blackboard.Blackboard.storage.get("/probe_roll", ""))
        if found == "end":
            felt.append(Felt("end", odometry[0], how="probe"))
        elif found in _PROBE_DIRECTIONS:
            felt.append(Felt("bend", odometry[0], direction=_PROBE_DIRECTIONS[found], how="probe"))
    elif (
        run.succeeded
        and step.pab == "straight"
        and (checked.stop_at_feature or checked.stop_at_change)
        and abs(moved) < abs(checked.distance_m) - 0.02
    ):
        sensed = {getattr(n, "sensed", None) for n in runner.tree.root.iterate()}
        how = next(
            (
                how
                for word, how in (
                    ("front_opening", "opening"),
                    ("rear_opening", "opening"),
                    ("blocked", "blocked"),
                    ("slope", "slope"),
                    ("diameter", "diameter"),
                )
                if word in sensed
            ),
            "pab",
        )
        at_m = odometry[0]
        if how == "slope":  # felt a little after it began: placed where it began
            back = max(
                (float(getattr(n, "sensed_back_m", 0.0)) for n in runner.tree.root.iterate()),
                default=0.0,
            )
            at_m -= math.copysign(back, moved)
        felt.append(Felt("feature", at_m, how=how))
    pab = PabOutcome(
        label=label,
        kind=step.pab,
        outcome="success" if run.succeeded else "failure",
        start_s=0.0,
        end_s=clock.now() - started,
        why=why,
        failing_node=failing,
    )
    return StepRun(
        run.succeeded,
        why,
        failing,
        [pab],
        odometry[0],
        felt,
        # a lost link stops the robot from the supervisor, no behaviour raising: the
        # step's error is the link's all the same, so that it exits 3 (DESIGN.md)
        error=run.error or link_cause(run, supervisor),
        ticks=run.ticks,
        stamp_s=odometry[1],
        off_wall=off_wall[0],
        openings=tuple(OffWall(n, at, back, behind[n]) for n, at, back in episodes),
    )
