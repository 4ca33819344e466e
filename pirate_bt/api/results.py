"""What a tree run returns: :class:`RunResult`, which says why.

Missions return :class:`~pirate_bt.task.mission.MissionResult` (the same fields,
plus one :class:`~pirate_bt.task.outcome.PabOutcome` per step of the plan); both
carry one :class:`~pirate_bt.safety.tally.Counters` type.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from pirate_bt.error_chain import portable_chained, same_values
from pirate_bt.errors import LinkError, UnpicklableError, portable_error
from pirate_bt.runner import RunResult as LoopResult
from pirate_bt.runner import StopReason
from pirate_bt.safety.tally import Counters
from pirate_bt.trace.coverage import Coverage

__all__ = [
    "RunResult",
    "UnpicklableError",
    "after_close",
    "closing_why",
    "exit_code",
    "portable_error",
]


def exit_code(succeeded: bool, error: BaseException | None) -> int:
    """The command line's exit code for a run: 0 success, 3 link error, 1 failure."""
    if succeeded:
        return 0
    return 3 if isinstance(error, LinkError) else 1


@dataclass(frozen=True)
class RunResult:
    """How a tree run ended, and why.

    Attributes:
        tree: The tree's name.
        status: ``"success"`` or ``"failure"`` (every end but success is a failure).
        stop: How the run stopped (``success``, ``failure``, ``time_limit``,
            ``exception``, ``interrupted``).
        why: The first cause, for people: the deepest failure a behaviour recorded
            (``stall: bend_3_drive draws 1.50 A at 0 mm/s for 0.55 s (commanded 80
            mm/s)``), the supervisor's own stop (``link lost``), an exception, or a
            time limit with the node still running. On success, the runner's line.
        failing_node: The path of the node where it failed (``bend/pass bend/front
            into turn``), or ``None``.
        sim_time_s: Clock time the run took (simulated on the simulator).
        wall_s: Wall time the run took.
        ticks: Ticks run.
        counters: Refusals, clips, link figures and, simulated, violations and damage.
        safe_state: The robot was left in its safe state (drives stopped, clamps held).
        target: Where it ran (``simulator: bend-right``, ``robot at /dev/ttyACM0``,
            ``no robot``).
        trace_path: The trace written, if any.
        error: The exception that ended the run, if one did.
        traceback: Its formatted traceback.
        loop: The runner's own result (tick durations, overruns, stopped nodes).
        coverage: Per node, what it did (ticks, transitions, successes, failures,
            halts, skips), counted as BehaviorTree.CPP's ``TreeObserver`` does:
            ``coverage.never_ran()``, ``coverage.never_failed(("guard", "condition"))``.
        close_error: Set when closing the link, after the run, could not make sure the
            robot stopped (its closing stop and the e-stop after it never acknowledged):
            the run is then a failure, exit 3, whatever the tree did, and ``why`` says so.
        after_stop: What was done after a failed run left the robot in a steep pipe
            with a half free (``None`` when nothing was): the free half clamped (*the
            rear half, left free in a steep pipe (pitch 66°), was clamped: both halves
            hold*), or why it could not be, plainly (*the robot may be unclamped in a
            riser: only its front half held it ...: the link is down ...*). ``why``
            still names the first cause.

    Example::

        result = pirate_bt.simulate_tree("straight", params={"distance": "0.2 m"})
        if not result.succeeded:
            print(f"{result.why} at {result.failing_node}")
        print(result.summary())             # the line `pirate-bt run` prints
        print(result.counters.refusals, result.safe_state)
    """

    tree: str
    status: str
    stop: StopReason
    why: str
    failing_node: str | None
    sim_time_s: float
    wall_s: float
    ticks: int
    counters: Counters = field(default_factory=Counters)
    safe_state: bool = False
    target: str = "no robot"
    trace_path: Path | None = None
    error: BaseException | None = None
    traceback: str | None = None
    loop: LoopResult | None = field(default=None, repr=False)
    coverage: Coverage | None = field(default=None, repr=False)
    close_error: LinkError | None = None
    after_stop: str | None = None

    @property
    def succeeded(self) -> bool:
        """True when the tree succeeded (``status == "success"``)."""
        return self.status == "success"

    def __eq__(self, other: object) -> bool:
        """Equal values, an ``error`` by its type, message and causes
        (:func:`~pirate_bt.error_chain.same_values`): one read back from another process
        equals its original."""
        if type(other) is not type(self):
            return NotImplemented
        return same_values(self, other)

    def __getstate__(self) -> dict[str, Any]:
        # to another process (a pool's worker, Dask) whatever a planner's node raised:
        # an exception that cannot be pickled and read back (a class whose __init__
        # takes two arguments) broke the pool, the result that says why lost with it
        state = dict(self.__dict__)
        error = portable_chained(self.error)
        if error is not self.error:
            state["error"] = error
            if self.loop is not None and self.loop.error is self.error:
                state["loop"] = replace(self.loop, error=error)
        return state

    @property
    def exit_code(self) -> int:
        """What ``pirate-bt run`` exits with: 0 success, 1 failure, 3 link error."""
        return 3 if self.close_error is not None else exit_code(self.succeeded, self.error)

    def summary(self) -> str:
        """One line for people, as ``pirate-bt run`` prints it (the names of a tree built
        in Python escaped as its ``why`` is: a line break as ``\\n``)."""
        from pirate_bt.behaviours.foreign import one_line

        node = one_line(self.failing_node) if self.failing_node else None
        where = f" at {node}" if node and not self.succeeded and node not in self.why else ""
        overruns = self.loop.overrun_count if self.loop is not None else 0
        return (
            f"{one_line(self.tree)}: {self.status.upper()} - {self.why}{where}"
            f" ({self.target}; {self.ticks} ticks, {self.sim_time_s:.2f} s clock,"
            f" {self.wall_s:.2f} s wall" + (f", {overruns} tick overruns" if overruns else "") + ")"
        )

    def as_dict(self) -> dict[str, Any]:
        """Plain JSON values (campaign rows, your own reports)."""
        return {
            "tree": self.tree,
            "status": self.status,
            "stop": str(self.stop),
            "why": self.why,
            "failing_node": self.failing_node,
            "sim_time_s": round(self.sim_time_s, 3),
            "wall_s": round(self.wall_s, 3),
            "ticks": self.ticks,
            "safe_state": self.safe_state,
            "target": self.target,
            "trace": str(self.trace_path) if self.trace_path is not None else None,
            "counters": self.counters.as_dict(),
            "coverage": self.coverage.as_dict() if self.coverage is not None else None,
            "after_stop": self.after_stop,
        }


def after_close(result: RunResult, close_error: LinkError | None) -> RunResult:
    """``result`` once its link is closed: unchanged, or, when the close could not make
    sure the robot stopped (``close_error``, see :attr:`RunResult.close_error`), a failure
    that says so: its ``why`` on a tree that succeeded (the first cause), after the
    run's own first cause on one that failed."""
    if close_error is None:
        return result
    why = closing_why(result.succeeded, result.why, close_error)
    return replace(result, status="failure", why=why, close_error=close_error)


def closing_why(succeeded: bool, why: str, close_error: LinkError) -> str:
    """The first cause of a run (tree, mission or navigation) whose close could not make
    sure the robot stopped: ``close_error`` itself when the run had succeeded, else the
    run's own first cause followed by it."""
    return str(close_error) if succeeded else f"{why}; then {close_error}"
