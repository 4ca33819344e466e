"""The navigation loop: planner code chooses each step from what the robot felt.

:func:`run_navigation` asks a :class:`~pirate_bt.task.navigation.Navigator` for a
:class:`~pirate_bt.task.navigation.Step`, checks it, runs it as its PAB's tree behind
the supervisor, and tells the navigator how it went, until the navigator says it is
done (``None``), a step fails, or a limit is reached. The public door is
:func:`pirate_bt.navigate`; docs/navigators.md is the user's guide.

- **With a map**, each step is planned on it from the belief
  (:class:`~pirate_bt.task.step_planner.StepPlanner`) and run as a one-step mission
  (:func:`~pirate_bt.task.mission.run_mission`): the localiser corrects the belief at
  every feature it recognises, a turn gets its approach leg, and a map disagreement
  stops the step safe; the navigator is told, and may go on from the belief.
- **Without a map**, each step runs its PAB's tree directly with the step's
  parameters; the belief is the odometry's distance along the way.

The guarantees: the navigator sees only its :class:`Observation` (it holds nothing
that reaches the robot); one that raises, takes longer than ``deadline_s`` of wall
time to answer, or answers with a step that cannot run ends the navigation in the
safe state, and ``why`` names the navigator and its error. Every decision (its
observation, its step, how long it took, how the step ended) is kept in the result
and, with a trace, written to ``navigation.jsonl`` beside one tick trace per step.
"""

from __future__ import annotations

import copy
import json
import logging
import math
import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any, TextIO

from pirate_bt.clock import Clock
from pirate_bt.errors import MAX_PATH, LocatedError, ValidationFailed, cut_reason, said_of
from pirate_bt.pipes import Network
from pirate_bt.robot.description import RobotDescription
from pirate_bt.robot.parts import Half
from pirate_bt.safety.tally import VerdictTally
from pirate_bt.task.localise import MAP_FRACTION
from pirate_bt.task.navigate_result import (
    FailedStep,
    NavigationResult,
    done_after_failures,
    first_then,
    unrecovered,
    went_on,
)
from pirate_bt.task.navigate_steps import StepRun, plan_mapped, run_blind, run_mapped
from pirate_bt.task.navigation import (
    Belief,
    BlindTrail,
    CheckedStep,
    Decision,
    Felt,
    InvalidStep,
    Navigator,
    Observation,
    Step,
    call_within,
    check_step,
    plain,
    raised_at,
)
from pirate_bt.task.outcome import PabOutcome, unsafe_note
from pirate_bt.task.plan import MissionPlan, robot_length_m
from pirate_bt.task.step_planner import StepPlanner
from pirate_bt.trace.attach import counter_values

__all__ = ["NavigationResult", "run_navigation"]

_log = logging.getLogger(__name__)

MAX_FAILED_IN_A_ROW = 3
"""After a map disagreement a navigator may go on; after this many failed steps in a
row it is stopped (the robot stays in its safe state)."""

MAX_IDLE_REPEATS = 3
"""A navigator that asks for the step it just took, after that step moved the robot
less than :data:`IDLE_M`, this many times in a row, is stopped: it would go round in
that loop to its step limit (a goal it cannot reach, a researcher's navigator that
does not see its step change nothing)."""

IDLE_M = 0.001
"""Less than this along the pipe, a step has not moved the robot."""

ODOMETRY_FRACTION = 0.05
"""Without a map, the belief may be off by this share of the distance driven."""


def _sensed(robot: RobotDescription, state: Any) -> dict[str, float | None]:
    """What the robot reads of the pipe where it stands: the diameter from the rear
    half's wall-contact angles, the slope and the heading from the IMU."""
    if state is None:
        return {"diameter_m": None, "front_diameter_m": None, "pitch_rad": None, "yaw_rad": None}
    clamp = robot.clamp
    tol = robot.safety.angle_tolerance
    low = min(c.angle for c in clamp.contact_angles) - tol
    high = max(c.angle for c in clamp.contact_angles) + tol

    def diameter(half: Half) -> float | None:
        # only a joint at a wall-contact angle reads the pipe: one at rest (before the
        # half first clamps) or swung off the wall (over an opening) reads nothing
        angles = sorted(
            a
            for m in robot.bend_modules(half)
            if m.name in state.joint_angle_rad
            and low <= (a := abs(state.joint_angle_rad[m.name])) <= high
        )
        return clamp.diameter_for(angles[len(angles) // 2]) if angles else None

    return {
        "diameter_m": diameter(Half.REAR),
        "front_diameter_m": diameter(Half.FRONT),
        "pitch_rad": state.imu_rad.get("pitch"),
        "yaw_rad": state.imu_rad.get("yaw"),
    }


def _odometer(counters: Callable[[], Any] | None) -> float | None:
    """The simulator's odometer (metres travelled along the pipe, both ways), or
    ``None`` on a robot."""
    if counters is None:
        return None
    value = getattr(counters(), "distance_m", None)
    return None if value is None else float(value)


def _origin(navigator: object, index: int) -> tuple[str | None, int]:
    """Where the navigator says its last step comes from (``origin``: a file and a line,
    as the route navigator keeps it), else ``None`` and the step's number. A file name
    that cannot be one line of a place (empty, or with a control character: it ended the
    navigation with a bare ``ValidationFailed`` when its step's tree was named after it),
    one longer than a file's name may be (it headed every step's trace whole) or a line
    that is a bool is no origin."""
    origin = getattr(navigator, "origin", None)
    if (
        isinstance(origin, tuple)
        and len(origin) == 2
        and isinstance(origin[0], str)
        and origin[0].isprintable()
        and origin[0].strip() != ""
        and len(origin[0]) <= MAX_PATH  # no file's name: it headed each step's trace whole
        and isinstance(origin[1], int)
        and not isinstance(origin[1], bool)
        and 0 < origin[1] <= 1_000_000
    ):
        return origin[0], origin[1]
    return None, index


def _decide(
    navigator: Navigator, obs: Observation, deadline_s: float, name: str, mapped: bool
) -> tuple[tuple[Step | None, tuple[str | None, int]], float, str | None, BaseException | None]:
    """Ask the navigator, on a thread of its own, within ``deadline_s`` of wall time:
    its step and, with a map (``mapped``), where it says the step comes from (its
    ``origin``, read on that thread too: a property that raised went out of the
    navigation as a bare exception, and one that hung had no deadline), the
    wall time it took, and why its answer is refused with the exception it raised, if
    it did."""

    def ask() -> tuple[Step | None, tuple[str | None, int]]:
        step = navigator.next_step(obs)
        return step, _origin(navigator, obs.step + 1) if mapped else (None, obs.step + 1)

    nothing: tuple[None, tuple[str | None, int]] = (None, (None, obs.step + 1))
    started = time.perf_counter()
    done, answer, exc = call_within(ask, deadline_s, f"navigator {name}")
    seconds = time.perf_counter() - started
    if not done:
        return (
            nothing,
            seconds,
            (
                f"navigator {name!r} took longer than its {deadline_s:g} s deadline to decide"
                f" step {obs.step + 1}"
            ),
            None,
        )
    if exc is not None:  # a navigator's error is a result, not a crash
        # the traceback is the planner's to read: kept in the result and logged
        _log.debug("navigator %r raised at %s", name, raised_at(exc), exc_info=exc)
        text = said_of(exc)  # one line; nothing after the type when empty
        said = f"navigator {name!r} raised {type(exc).__name__}" + (f": {text}" if text else "")
        # bounded as every reason is: a 10 MB message was printed twice and written
        # three times into navigation.jsonl (the decision, the result, its why)
        said = cut_reason(said)
        return nothing, seconds, said, exc
    return answer, seconds, None, None


class _Records:
    """``navigation.jsonl``: one record per line, flushed as it is written."""

    def __init__(self, directory: Path | None) -> None:
        self.directory = directory
        self._file: TextIO | None = None
        if directory is not None:
            directory.mkdir(parents=True, exist_ok=True)
            self._file = (directory / "navigation.jsonl").open("w", encoding="utf-8")

    def write(self, record: dict[str, Any]) -> None:
        if self._file is not None:
            text = json.dumps(_bounded(record), allow_nan=False, default=str)
            self._file.write(text + "\n")
            self._file.flush()

    def step_trace(self, index: int) -> Path | None:
        return None if self.directory is None else self.directory / f"step-{index:03d}.jsonl"

    def close(self) -> None:
        if self._file is not None:
            self._file.close()
            self._file = None


def _bounded(value: Any) -> Any:
    """A record with every text cut to :data:`~pirate_bt.errors.MAX_PATH` characters
    (its middle left out): a navigator's step of a 1 MB parameter was written whole."""
    if isinstance(value, str):
        return cut_reason(value, MAX_PATH)
    if isinstance(value, dict):
        return {_bounded(k): _bounded(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_bounded(v) for v in value]
    return value


def run_navigation(
    navigator: Navigator,
    robot: RobotDescription,
    supervisor: Any,
    clock: Clock,
    *,
    name: str,
    network: Network | None = None,
    truth_for: Callable[[MissionPlan], Callable[[], float | None]] | None = None,
    truth_now: Callable[[], float | None] | None = None,
    counters: Callable[[], Any] | None = None,
    trace_dir: Path | None = None,
    period_s: float = 0.05,
    max_time_s: float = 3600.0,
    deadline_s: float = 5.0,
    max_steps: int = 500,
    map_tolerance: float = MAP_FRACTION,
    scenario: str | None = None,
    seed: int | None = None,
    count_from_open: bool = False,
) -> NavigationResult:
    """Run ``navigator`` step by step on a supervised robot (see the module docstring).

    Args:
        navigator: Anything with ``next_step(obs) -> Step | None``.
        robot: The robot description.
        supervisor: The supervisor holding the connected robot.
        clock: The run's clock.
        name: The navigator's name, for results and messages.
        network: The map (``None``: navigate without one).
        truth_for: With a map: the simulator's truth on a plan's map, for results.
        truth_now: Without a map: the simulator's distance along the pipe from the
            start, for results.
        counters: The simulator's counters, for the trace and the result.
        trace_dir: Write ``navigation.jsonl`` and one ``step-001.jsonl``... per step here.
        period_s: Tick period.
        max_time_s: Clock time the whole navigation may take.
        deadline_s: Wall time the navigator may take for one decision.
        max_steps: Steps the navigation may take.
        map_tolerance: How far the map's lengths may be off (see ``simulate_mission``).
        scenario: Network name for the trace headers.
        seed: Simulator seed for the trace headers.
        count_from_open: Count the link's and the simulator's figures from the moment
            the link opened, as a tree run does: a slide as the robot was put in a
            steep pipe, before its first clamp held, is then in the counters and ``why``.
    """
    wall_started = time.perf_counter()
    start_s = clock.now()
    planner = StepPlanner(network, robot, source=f"<navigator {name}>") if network else None
    # the navigator's own copy of the map: one that mutates it (its segments' lists)
    # changed what later steps were planned on, or failed the planner with IndexError
    shown_map = copy.deepcopy(network) if network is not None else None
    belief = planner.start_m if planner is not None else 0.0
    trail = BlindTrail()  # with no map: what the steps passed (probe-turn, the backward PABs)
    records = _Records(trace_dir)
    records.write(
        {
            "type": "navigation",
            "navigator": name,
            "map": network.name if network is not None else None,
            "scenario": scenario,
            "seed": seed,
            "deadline_s": deadline_s,
            "max_time_s": max_time_s,
        }
    )
    tally = VerdictTally(supervisor, from_open=count_from_open)
    result = NavigationResult(navigator=name, status="failure", why="", trace_dir=trace_dir)
    felt: list[Felt] = []
    last: PabOutcome | None = None
    history: list[tuple[Step, str]] = []
    # on the simulator from the start: a navigation that ran no step had None; on the
    # belief's scale (a map's: the front tip at the entry), where it said 0.00 m
    truth_m: float | None = truth_now() if truth_now is not None else None
    if truth_m is not None:
        truth_m += belief
    ran: StepRun | None = None
    odometer_m = 0.0  # how far each step moved the belief, summed
    fixed_at_m = 0.0  # the odometer at the last fix
    fixed_feature: str | None = None  # the feature of the last fix
    failed_in_a_row = 0
    idle_repeats = 0  # the same step again, after it moved the robot nowhere
    failures: list[FailedStep] = []  # every step that failed, in order
    disagreements: list[FailedStep] = []  # those that failed on a map disagreement
    fixed_after = 0  # the last step that succeeded on a fix on the map (0: none)
    odometer = _odometer(counters)  # the simulator's, at the start
    robot_length = robot_length_m(robot)
    behind = robot.behind_front_tip_m()
    try:
        for index in range(1, max_steps + 2):
            if ran is not None and ran.mission is not None and ran.mission.fixes:
                last_fix_m = ran.mission.fixes[-1].after_m
                fixed_feature = ran.mission.fixes[-1].feature
                # the odometer at that fix: the step's distance driven after it
                fixed_at_m = odometer_m - abs(ran.mission.belief_m - last_fix_m)
                if ran.succeeded:  # belief and map agree again
                    fixed_after = index - 1
            if planner is not None:  # the distance driven since the last fix, not the net
                uncertainty = map_tolerance * (odometer_m - fixed_at_m)
            else:
                uncertainty = ODOMETRY_FRACTION * odometer_m
            obs = Observation(
                step=index - 1,
                belief=Belief(
                    belief,
                    planner.segment_at(belief) if planner is not None else None,
                    uncertainty,
                    on_map=planner is not None,
                ),
                felt=tuple(felt),
                last=last,
                map=shown_map,
                time_s=clock.now() - start_s,
                choices=dict(planner.choices) if planner is not None else {},
                history=tuple((plain(s), o) for s, o in history),  # the navigator's to edit
                robot_length_m=robot_length,
                imu_behind_m=behind[robot.rotational_module().name],
                joint_behind_m=min(behind[m.name] for m in robot.bend_modules(Half.FRONT)),
                rear_joint_behind_m=max(behind[m.name] for m in robot.bend_modules(Half.REAR)),
                off_wall=ran.openings if ran is not None else (),
                **_sensed(robot, supervisor.state()),
            )
            if index > max_steps:
                result.why = f"navigator {name!r} reached its limit of {max_steps} steps"
                supervisor.safe_state(result.why)
                result.why += went_on(disagreements)
                break
            # the decision records what the navigator was told, not what it wrote into it
            told = replace(
                obs, choices=dict(obs.choices), history=tuple((plain(s), o) for s, o in history)
            )
            try:
                (step, origin), seconds, error, raised = _decide(
                    navigator, obs, deadline_s, name, planner is not None
                )
            except KeyboardInterrupt as exc:
                # Ctrl-C while the navigator decides: a failure that leaves the robot
                # safe, as one during a step is (it went out of the navigation, which
                # neither stopped the robot nor said why in its records)
                said = f"interrupted ({str(exc) or 'Ctrl-C'}) while navigator {name!r} decided"
                result.why = first_then(name, failures, f"{said} step {index}")
                result.failing_node = failures[0].failing_node if failures else None
                supervisor.safe_state(result.why)
                break
            if isinstance(step, Step):  # a copy: its own __repr__ or __eq__ is not reached
                step = plain(step)  # again, and the navigator's later edits change nothing
            checked: CheckedStep | None = None
            plan: MissionPlan | None = None
            if error is None and step is not None:
                try:
                    checked = check_step(step)
                    if planner is not None:
                        rolled = step.pab == "bend" and "roll" in step.params
                        roll = checked.roll_rad if rolled else None
                        source, line = origin
                        plan = plan_mapped(
                            planner, checked.route_line(), line, belief, roll, source, robot_length
                        )
                    else:
                        checked.check_blind(belief, trail)
                except InvalidStep as exc:  # its message starts with the step
                    error = f"navigator {name!r} asked for an invalid step: {exc}"
                except (LocatedError, ValidationFailed) as exc:
                    error = f"navigator {name!r} asked for an invalid step {step!r}: {exc}"
            decision = Decision(index, told, step, seconds, error)
            if error is not None:
                result.decisions.append(decision)
                where = {} if raised is None else {"raised_at": raised_at(raised)}
                records.write({"type": "decision", **decision.to_json(), **where})
                # the first cause first: a step that failed before (the navigator went
                # on after a map disagreement), then the navigator's own error
                result.why = first_then(name, failures, error)
                result.failing_node = failures[0].failing_node if failures else None
                result.error = raised
                result.navigator_raised = raised is not None
                supervisor.safe_state(error)
                break
            if step is None:
                result.decisions.append(decision)
                records.write({"type": "decision", **decision.to_json()})
                succeeded, result.why, result.failing_node = done_after_failures(
                    name,
                    index - 1,
                    failures,
                    fixed_after=fixed_after,
                    unsafe=unsafe_note(tally.counters()),
                )
                result.status = "success" if succeeded else "failure"
                if not succeeded:  # a failure leaves the robot safe (the first cause kept)
                    supervisor.safe_state(result.why)
                break
            assert checked is not None
            elapsed = clock.now() - start_s
            if elapsed >= max_time_s:
                result.why = f"navigation time limit reached ({max_time_s:g} s)"
                supervisor.safe_state(result.why)
                result.why += went_on(disagreements)
                result.decisions.append(decision)
                break
            if supervisor.in_safe_state and ran is not None and ran.disagreement:
                supervisor.resume()  # the navigator chose to go on from the belief
            offset = clock.now() - start_s
            if plan is not None:
                ran = run_mapped(
                    plan,
                    robot,
                    supervisor,
                    clock,
                    truth_for=truth_for,
                    counters=counters,
                    trace_path=records.step_trace(index),
                    period_s=period_s,
                    max_time_s=max_time_s - elapsed,
                    belief_m=belief,
                    map_tolerance=map_tolerance,
                    since_fix_m=odometer_m - fixed_at_m,
                    fixed_before=fixed_feature,
                )
                if ran.mission is not None:  # a tee the map lacks, passed: the step re-planned
                    result.notes += [f"step {index} ({step!r}): {n}" for n in ran.mission.replans]
                if not ran.succeeded and planner is not None:
                    # a turn never felt was not taken: the belief stays on the main line
                    fixes = ran.mission.fixes if ran.mission is not None else ()
                    for tee in planner.forget_unfelt(plan, (f.feature for f in fixes)):
                        ran.why += (
                            f"; no turn into the branch of {tee!r} was felt: the robot is believed"
                            f" on the main line, in {planner.segment_at(ran.belief_m)!r}"
                        )
            else:
                ran = run_blind(
                    checked,
                    index,
                    robot,
                    supervisor,
                    clock,
                    counters=counters,
                    trace_path=records.step_trace(index),
                    period_s=period_s,
                    max_time_s=max_time_s - elapsed,
                    belief_m=belief,
                    scenario=scenario,
                    seed=seed,
                    stamp_s=ran.stamp_s if ran is not None else math.nan,
                )
                if truth_now is not None:
                    ran.truth_m = truth_now()
                if ran.succeeded:
                    trail.note(checked, ran.felt, ran.off_wall)
            if not ran.succeeded and clock.now() - start_s >= max_time_s - period_s / 2:
                # the budget cut the step short: that is the cause, said as the caller set it
                ran.why = (
                    f"navigation time limit reached ({max_time_s:g} s) in step {index}"
                    f" ({step!r}): {ran.why}"
                )
            result.steps = index
            result.ticks += ran.ticks
            moved_m = abs(ran.belief_m - belief)
            repeated = bool(history) and history[-1][0] == step
            odometer_m += moved_m
            belief = ran.belief_m
            truth_m = ran.truth_m
            felt = ran.felt
            shifted = [
                replace(
                    p,
                    start_s=None if p.start_s is None else p.start_s + offset,
                    end_s=None if p.end_s is None else p.end_s + offset,
                )
                for p in ran.pabs
            ]
            result.pabs.extend(shifted)
            if ran.mission is not None:
                result.missions.append(ran.mission)
            outcome = "success" if ran.succeeded else "failure"
            last = PabOutcome(
                label=f"step {index}: {step!r}",
                kind=step.pab,
                outcome=outcome,
                start_s=offset,
                end_s=clock.now() - start_s,
                why=ran.why if not ran.succeeded else "",
                failing_node=ran.failing_node,
            )
            history.append((step, outcome))
            decision = replace(decision, outcome=outcome)
            result.decisions.append(decision)
            records.write(
                {
                    "type": "decision",
                    **decision.to_json(),
                    "trace": None if records.directory is None else f"step-{index:03d}.jsonl",
                    "why": last.why,
                }
            )
            if not ran.succeeded:
                failures.append(FailedStep(index, step, ran.why, ran.failing_node))
                if ran.disagreement:
                    disagreements.append(failures[-1])
            failed_in_a_row = 0 if ran.succeeded else failed_in_a_row + 1
            if not ran.succeeded and failed_in_a_row >= MAX_FAILED_IN_A_ROW:
                first = failures[0]  # the first cause first, then the row that stopped it
                result.why = (
                    f"{first.why} ({first.named()}); navigator {name!r} went on, and steps"
                    f" {index - failed_in_a_row + 1} to {index} failed in a row, the last:"
                    f" {ran.why}; it is stopped"
                )
                result.failing_node = first.failing_node
                break
            idle_repeats = (
                idle_repeats + 1
                if ran.succeeded and repeated and moved_m < IDLE_M and step.pab != "wait"
                else 0  # a wait stands still by design: it is never stuck
            )
            if idle_repeats >= MAX_IDLE_REPEATS:
                result.why = (
                    f"navigator {name!r} is stuck: it asked for {step!r} again"
                    f" {idle_repeats} times in a row, and the robot did not move"
                    f" (believed at {belief:.2f} m)"
                )
                supervisor.safe_state(result.why)
                result.why += went_on(disagreements)
                break
            if not ran.succeeded and not ran.disagreement:
                if unrecovered(disagreements, fixed_after, ran.error):
                    # the step failed in a pipe not as the map says, before belief and map
                    # agreed again: the disagreement is the first cause, the failure after
                    later = f"step {index} ({step!r}) failed: {ran.why}"
                    result.why = first_then(name, disagreements, later)
                    result.failing_node = disagreements[0].failing_node
                else:
                    result.why = ran.why + went_on(disagreements)
                    result.failing_node = ran.failing_node
                result.error = ran.error
                break
    finally:
        tally.detach()
        result.belief_m = belief
        result.truth_m = truth_m
        result.off_wall = ran.openings if ran is not None else ()
        result.sim_time_s = clock.now() - start_s
        result.wall_s = time.perf_counter() - wall_started
        result.safe_state = bool(supervisor.in_safe_state)
        result.counters = tally.counters()
        result.sim = counter_values(counters() if counters is not None else None)
        # simulated: the simulator's odometer (the truth); on a robot: the belief's
        ended = _odometer(counters)
        result.distance_m = odometer_m if ended is None or odometer is None else ended - odometer
        records.write(
            {
                "type": "end",
                "status": result.status,
                "why": result.why,
                "failing_node": result.failing_node,
                "steps": result.steps,
                "belief_m": round(belief, 4),
                "truth_m": None if truth_m is None else round(truth_m, 4),
                "sim_time_s": round(result.sim_time_s, 4),
            }
        )
        records.close()
    return result
