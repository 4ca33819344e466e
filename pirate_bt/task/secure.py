"""After a run that failed in a steep pipe with one half free: clamp it, deliberately.

A stop keeps the clamps as they were (the safe state never releases, DESIGN.md), so
a bend or T-joint PAB stopped half-way through leaves one half steered, free, while
the other alone holds the robot in a riser. Nothing falls; but the robot is handed
back on one half, and a fault on that half (a joint that stalls, a board that loses
power) drops it. :func:`hold_both` then leaves the safe state, runs the ``hold`` tree
(``trees/lib/hold.yaml``: clamp the rear, move the front module clear, clamp the
front; every command checked by the supervisor, a clamped half confirmed at once)
and enters the safe state again with the same first cause. It does nothing on the
level, with both halves clamped or both free (the supervisor's protective hold),
e-stopped, with the link unfit for commands, or with an operator in control.
"""

from __future__ import annotations

import logging
import math
from typing import Any

from pirate_bt.clock import Clock
from pirate_bt.robot import Half
from pirate_bt.robot.description import RobotDescription

__all__ = ["HOLD_TIME_S", "hold_both"]

log = logging.getLogger(__name__)

HOLD_TIME_S = 20.0
"""The longest the clamp of the free half may take (clock time)."""


def hold_both(
    robot: RobotDescription,
    supervisor: Any,
    clock: Clock,
    *,
    period_s: float = 0.05,
) -> str | None:
    """Clamp the free half of a robot left on one half in a steep pipe.

    Returns:
        What was done, for the result's notes, or ``None`` when nothing was.
    """
    from pirate_bt.resources import data_dir
    from pirate_bt.runner import Runner
    from pirate_bt.safety.checks import ClampState
    from pirate_bt.task.outcome import explain_run
    from pirate_bt.treefile import load_tree

    state = supervisor.state()
    if state is None:
        return None
    pitch = state.imu_rad.get("pitch")
    if pitch is None or abs(pitch) <= robot.motion.max_unclamped_slope:
        return None
    halves = supervisor.half_states()
    free = [h for h in Half if halves.get(h) is not ClampState.CLAMPED]
    where = f"in a steep pipe (pitch {math.degrees(pitch):.0f}°)"
    unable = _cannot_clamp(supervisor)
    if free and unable is not None:  # nothing may move it: say what holds it, plainly
        note = _left_unheld(free, where, unable)
        log.warning("after the stop: %s", note)
        return note
    if len(free) != 1:
        return None
    reason = supervisor.safe_state_reason or "run ended without success"
    error = supervisor.safe_state_error
    supervisor.resume()  # a deliberate, checked clamp: the safe state never clamps
    try:
        loaded = load_tree(
            str(data_dir("trees") / "lib" / "hold.yaml"),
            robot=robot,
            clock=clock,
            supervisor=supervisor,
        )
        runner = Runner.supervised(
            loaded,
            supervisor,
            clock=clock,
            end_reason=lambda: reason,
            period_s=period_s,
            max_time_s=HOLD_TIME_S,
        )
        run = runner.run()
    finally:
        if not supervisor.in_safe_state:
            supervisor.safe_state(reason, error=error)
    if run.succeeded:
        note = f"the {free[0]} half, left free {where}, was clamped: both halves hold"
    else:
        why, _node = explain_run(run, runner.tree.root)
        note = f"the {free[0]} half, left free {where}, could not be clamped: {why}"
    log.warning("after the stop: %s", note)
    return note


def _cannot_clamp(supervisor: Any) -> str | None:
    """Why no clamp may be sent now (the link down, an e-stop, an operator in control),
    or ``None``."""
    problem = supervisor.link_problem()
    if supervisor.estopped:
        return "the robot is e-stopped (an e-stop keeps the clamps as they are)"
    if problem is not None:
        return f"the link is down ({problem.reason}: {problem.detail})"
    if supervisor.tree_paused:  # an operator has the robot (MANUAL): theirs to hold
        return "an operator holds the robot (manual mode)"
    return None


def _left_unheld(free: list[Half], where: str, why: str) -> str:
    """The note for a robot left with a free half in a steep pipe that nothing may clamp
    now: which half may still hold it (by its last readings), and why none was clamped."""
    if len(free) == 2:
        return (
            f"the robot may be unclamped in a riser: no half held it {where} at the last"
            f" reading, and none could be clamped: {why}"
        )
    other = Half.REAR if free[0] is Half.FRONT else Half.FRONT
    return (
        f"the robot may be unclamped in a riser: only its {other} half held it {where} at"
        f" the last reading; the {free[0]} half, left free, could not be clamped: {why}"
    )
