"""What a run's hooks see (:class:`TickInfo`) and how it ended (:class:`RunResult`).

The tick loop itself is :mod:`pirate_bt.runner`, which re-exports these.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field
from typing import Any

import py_trees
from py_trees.common import Status

from pirate_bt.error_chain import hash_values, portable_chained, same_values
from pirate_bt.errors import REASON_LIMIT, cut_reason

__all__ = [
    "REASON_LIMIT",
    "Overrun",
    "RunInterrupted",
    "RunResult",
    "StopReason",
    "TickInfo",
    "cut_reason",
]


class StopReason(enum.StrEnum):
    """Why a run ended."""

    SUCCESS = "success"
    FAILURE = "failure"
    TIME_LIMIT = "time_limit"
    EXCEPTION = "exception"
    INTERRUPTED = "interrupted"


@dataclass(frozen=True, slots=True)
class Overrun:
    """A tick that took longer than the budget."""

    tick: int
    duration_s: float
    budget_s: float


@dataclass(frozen=True, slots=True)
class TickInfo:
    """What a hook sees.

    Attributes:
        tick: Tick number, from 1.
        time_s: Clock time at the start of the tick (seconds since the run began).
        tree: The ``py_trees`` tree (visit it for node statuses).
        status: The root's status after the tick (``None`` in pre-tick hooks).
        duration_s: Wall time the tick took (``None`` in pre-tick hooks).
    """

    tick: int
    time_s: float
    tree: py_trees.trees.BehaviourTree
    status: Status | None = None
    duration_s: float | None = None


@dataclass(frozen=True)
class RunResult:
    """How a run ended.

    Attributes:
        outcome: ``"success"`` or ``"failure"`` (every non-success end is a failure).
        reason: Why it ended, as a :class:`StopReason`.
        message: One line for people, whole (the trace's end record keeps it; the
            safe-state reason the runner gives is cut to :data:`REASON_LIMIT`
            characters, and so is the API's ``why``).
        ticks: Ticks completed or attempted.
        sim_time_s: Clock time the run took (simulated time on a SimClock).
        wall_time_s: Wall time the run took.
        failing_node: Path of the node that raised (``None`` if none raised).
        error: The exception that ended the run, if any.
        traceback: Its formatted traceback.
        overruns: Ticks over budget (at most ``max_overruns_kept`` listed).
        overrun_count: All ticks over budget.
        max_tick_s: Longest tick (wall time).
        mean_tick_s: Mean tick (wall time).
        safe_state_called: The safe-state callback ran.
        stopped_nodes: Paths of the RUNNING nodes the runner stopped.
        paused_ticks: Ticks skipped because the tree was paused (an operator in MANUAL).
        settle_ticks: Ticks after the tree's end, while the robot came to rest (the
            runner's ``settle``); counted in ``ticks`` too.
    """

    outcome: str
    reason: StopReason
    message: str
    ticks: int
    sim_time_s: float
    wall_time_s: float
    failing_node: str | None = None
    error: BaseException | None = None
    traceback: str | None = None
    overruns: tuple[Overrun, ...] = ()
    overrun_count: int = 0
    max_tick_s: float = 0.0
    mean_tick_s: float = 0.0
    safe_state_called: bool = False
    stopped_nodes: tuple[str, ...] = field(default_factory=tuple)
    paused_ticks: int = 0
    settle_ticks: int = 0

    @property
    def succeeded(self) -> bool:
        return self.outcome == "success"

    def __eq__(self, other: object) -> bool:
        """Equal values, an ``error`` by its type, message and causes
        (:func:`~pirate_bt.error_chain.same_values`): one read back from another process
        equals its original."""
        if type(other) is not type(self):
            return NotImplemented
        return same_values(self, other)

    def __hash__(self) -> int:
        return hash_values(self)

    def __getstate__(self) -> dict[str, Any]:
        # to another process (a pool's worker, with a RunInterrupted) whatever a
        # planner's node raised: one that cannot be read back goes as an
        # UnpicklableError of its type's name and message (as the API's RunResult)
        state = dict(self.__dict__)
        state["error"] = portable_chained(self.error)
        return state


class RunInterrupted(KeyboardInterrupt):
    """A Ctrl-C that came as the run ended (in a node's ``terminate()``, the tree's
    ``shutdown()``), let out of :meth:`~pirate_bt.runner.Runner.run` only once the robot
    was left in its safe state and the run's outputs were written: a
    ``KeyboardInterrupt`` still (it stops the program), with how the run ended.

    Attributes:
        result: The run's :class:`RunResult`.
    """

    def __init__(self, result: RunResult) -> None:
        super().__init__(result.message)
        self.result = result

    def __reduce__(self) -> tuple[Any, ...]:
        # made again from its result, not its message (a process pool's worker sends it
        # back pickled: read back from the message, it raised AttributeError there)
        return (type(self), (self.result,), dict(self.__dict__))
