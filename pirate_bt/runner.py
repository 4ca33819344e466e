"""The tick loop: rate, clock, exception safety and the safe stop.

:class:`Runner` ticks a ``py_trees`` tree at a fixed period on the injected
clock until the root returns SUCCESS or FAILURE, or a time limit passes. On a
:class:`~pirate_bt.clock.SimClock` the sleep between ticks advances simulated
time (and with it the simulator), so runs are fast and deterministic; with
``realtime=True`` the runner also waits in wall time, for watching a simulated run.

What py_trees leaves to its user, the runner does:

- **Exceptions.** If a behaviour raises, the runner records the failing node's
  path (``root/approach/clamp front``) and the traceback, stops every RUNNING
  node (deepest first, so ``terminate()`` cancels motion), calls the safe-state
  callback (the supervisor's "stop drives, hold clamps") and ends with failure.
- **Ctrl-C.** A ``KeyboardInterrupt`` during a tick or a wait is handled the
  same way; finish hooks still run, so traces are written (a Ctrl-C in one of them
  ends the run interrupted and the others still run). (``pirate-bt`` raises
  one for SIGTERM too.) A second Ctrl-C during the safe stop does not cut it short:
  the safe state is asked for again. A Ctrl-C raised in a node's ``terminate()`` as
  the runner stops the running nodes goes out of :meth:`Runner.run`, to stop the
  program, but only once the other nodes are stopped, the safe state called (the
  first cause kept) and the finish hooks run.
- **Any non-success end** (failure, time limit) also stops running nodes and
  calls the safe state: the robot is left safe whenever a run does not succeed.
- **Tick budget.** Each tick's duration (wall time, ``time.perf_counter``) is
  compared with a budget (default: the period); overruns are counted and listed.

Hooks: ``pre_tick`` hooks run before each tick (poll the robot link here),
``post_tick`` hooks after (the trace writer), ``finish`` hooks once with the
:class:`RunResult`. A hook that raises is treated like a behaviour that raises; a
finish hook that raises (a trace that cannot be completed) turns a successful run
into a failure (``exception``), so that what was asked for is never silently
missing; after a run that failed, its first cause is kept and the hook's error is
logged as a warning. Tracebacks are logged at DEBUG only: the result carries them.
"""

from __future__ import annotations

import dataclasses
import logging
import threading
import time
import traceback
from collections.abc import Callable
from contextlib import AbstractContextManager
from typing import Any

import py_trees
from py_trees.common import Status

from pirate_bt.clock import Clock
from pirate_bt.errors import said_of
from pirate_bt.run_result import (
    Overrun,
    RunInterrupted,
    RunResult,
    StopReason,
    TickInfo,
)
from pirate_bt.tree_tick import culprit as _culprit
from pirate_bt.tree_tick import halted_by, link_lost_note, node_path, tick_tree

__all__ = [
    "SETTLE_LIMIT_S",
    "Overrun",
    "RunInterrupted",
    "RunResult",
    "Runner",
    "StopReason",
    "TickInfo",
    "halted_by",
    "link_lost_note",
    "node_path",
    "tick_tree",
]

_log = logging.getLogger("pirate_bt.runner")

_RAISED = (Exception, SystemExit, GeneratorExit)
"""What a node, a hook or a callback may raise that the runner holds: anything but
Ctrl-C (``KeyboardInterrupt``). A ``sys.exit()`` in a behaviour or a hook went out of
:meth:`Runner.run` past the safe stop, the robot still driving (probe of 2026-11-30)."""


Hook = Callable[[TickInfo], None]

SETTLE_LIMIT_S = 2.0
"""How long (clock time) the end of a run waits, by default, for the robot to come to
rest (the runner's ``settle``): a drive stopped at its top speed ramps down in a few
tenths of a second."""


class Runner:
    """Ticks a tree until it finishes, a time limit passes, or something goes wrong.

    Args:
        tree: A ``BehaviourTree``, a root behaviour, or a
            :class:`~pirate_bt.treefile.LoadedTree` (its blackboard defaults are
            written before the first tick).
        clock: The injected clock (tick times, time limit, sleeping).
        period_s: Time between tick starts.
        max_time_s: Stop with failure after this much clock time (``None``: no limit).
        tick_budget_s: Longest acceptable tick in wall time (default: ``period_s``).
        safe_state: Called when a run ends without success (the supervisor's safe state).
        realtime: On a simulated clock, also wait in wall time so the run can be watched.
        setup_timeout_s: Passed to ``BehaviourTree.setup`` (in the main thread only: py_trees
            times it with a signal, so a run in another thread sets up without a limit).
        max_overruns_kept: How many overruns to list in the result.
        paused: Asked after the pre-tick hooks of every tick; while it answers
            ``True`` the tree is not ticked (its RUNNING nodes keep their state) but
            the post-tick hooks still run, so a trace shows the pause. The
            supervisor's ``tree_paused`` (an operator in MANUAL mode) goes here;
            the time limit keeps counting.
        halted: Asked after the pre-tick hooks of every tick, before ``paused``; a
            text ends the run at once as a failure with that text as its message
            (the post-tick hooks see the tick, untouched). The supervisor's
            ``run_halted`` goes here: the robot held in its safe state or e-stopped
            with no operator to go on, where a tree of waits and conditions would
            otherwise run on to success.
        settle: Asked at the end of every run, whatever its outcome (after
            ``safe_state``): is the robot at rest? While it answers ``False``, for at
            most ``settle_limit_s`` of clock time, the runner goes on ticking without
            the tree: the pre- and post-tick hooks run (the supervisor polls the link,
            odometry counts, the trace records the tick with the root's final status),
            one period apart. The supervisor's ``come_to_rest`` goes here, so that a
            run hands back a robot whose wheels have stopped. These ticks count in the
            result's ``ticks`` and ``settle_ticks`` and its clock time; an error in
            them is logged and ends the settling, never the result.
        settle_limit_s: The longest the end of a run waits for ``settle``.
        rest_unknown: Asked if the robot is still not at rest at ``settle_limit_s``: a text
            when its state cannot be known (:func:`link_lost_note`), logged instead.
    """

    def __init__(
        self,
        tree: Any,
        *,
        clock: Clock,
        period_s: float = 0.05,
        max_time_s: float | None = None,
        tick_budget_s: float | None = None,
        safe_state: Callable[[], None] | None = None,
        realtime: bool = False,
        setup_timeout_s: float = 15.0,
        max_overruns_kept: int = 100,
        paused: Callable[[], bool] | None = None,
        halted: Callable[[], str | None] | None = None,
        settle: Callable[[], bool] | None = None,
        settle_limit_s: float = SETTLE_LIMIT_S,
        rest_unknown: Callable[[], str | None] | None = None,
    ) -> None:
        if period_s <= 0:
            raise ValueError(f"period must be positive, got {period_s}")
        self._loaded = None
        if isinstance(tree, py_trees.trees.BehaviourTree):
            self.tree = tree
        elif isinstance(tree, py_trees.behaviour.Behaviour):
            self.tree = py_trees.trees.BehaviourTree(tree)
        elif hasattr(tree, "behaviour_tree"):
            self._loaded = tree
            self.tree = tree.behaviour_tree()
        else:
            raise TypeError(f"cannot run {type(tree).__name__}; give a behaviour or a tree")
        self.clock = clock
        self.period_s = period_s
        self.max_time_s = max_time_s
        self.tick_budget_s = period_s if tick_budget_s is None else tick_budget_s
        self.safe_state = safe_state
        self.stop_message: str | None = None
        """Why the last run ended, set before ``safe_state`` is called."""
        self.realtime = realtime
        self.setup_timeout_s = setup_timeout_s
        self.max_overruns_kept = max_overruns_kept
        self.paused = paused
        self.halted = halted
        self.settle = settle
        self.settle_limit_s = settle_limit_s
        self.rest_unknown = rest_unknown
        self.pre_tick: list[Hook] = []
        self.post_tick: list[Hook] = []
        self.finish: list[Callable[[RunResult], None]] = []
        self.guard: Callable[[], AbstractContextManager[object]] | None = None
        """Entered around each :meth:`run` (``None``: none): a connection's runner holds
        its connection with it, so that one tree at a time ticks the robot, and a run
        asked for while another runs on it is refused before anything moves."""

    @classmethod
    def supervised(
        cls,
        tree: Any,
        supervisor: Any,
        *,
        clock: Clock,
        end_reason: Callable[[], str],
        tick_supervisor: bool = True,
        **options: Any,
    ) -> Runner:
        """A runner wired to a supervisor as the task layer's runs are: a run that does
        not succeed ends in ``supervisor.end_safe(end_reason())``, one the supervisor
        cannot let go on (``run_halted``) ends at the next tick, the robot is brought to
        rest at the end (``come_to_rest``), and, unless ``tick_supervisor`` is false
        (the caller ticks it in its own hook), the supervisor ticks before each tick.
        ``options`` are the constructor's (``period_s``, ``max_time_s``, ...)."""
        runner = cls(
            tree,
            clock=clock,
            safe_state=lambda: supervisor.end_safe(end_reason()),
            halted=lambda: halted_by(supervisor, runner.tree.root),
            settle=supervisor.come_to_rest,
            rest_unknown=lambda: link_lost_note(supervisor),
            **options,
        )
        if tick_supervisor:
            runner.add_pre_tick(lambda _info: supervisor.tick())
        return runner

    def add_pre_tick(self, hook: Hook) -> None:
        """Run ``hook(info)`` before every tick (e.g. poll the robot link)."""
        self.pre_tick.append(hook)

    def add_post_tick(self, hook: Hook) -> None:
        """Run ``hook(info)`` after every tick (e.g. the trace writer)."""
        self.post_tick.append(hook)

    def add_finish(self, hook: Callable[[RunResult], None]) -> None:
        """Run ``hook(result)`` once when the run has ended (flush and close files)."""
        self.finish.append(hook)

    # -- the loop

    def run(self) -> RunResult:
        """Set the tree up and tick it to the end; never raises for a behaviour's error.

        Returns:
            The :class:`RunResult`; ``outcome`` is ``"failure"`` for every end but success.

        Raises:
            KeyboardInterrupt: Ctrl-C raised in a node's ``terminate()`` (or its
                ``shutdown()``) as the run ended; raised once the robot is in its safe
                state and the finish hooks have seen the result (the first cause).
            Exception: what :attr:`guard` raises to refuse the run, before its first tick
                (a connection's ``InputError``: it runs a tree already).
        """
        if self.guard is None:
            return self._run()
        with self.guard():
            return self._run()

    def _run(self) -> RunResult:
        wall0 = time.perf_counter()
        start_s = self.clock.now()
        ticks = 0
        durations_total = 0.0
        max_tick = 0.0
        overruns: list[Overrun] = []
        overrun_count = 0
        paused_ticks = 0
        reason: StopReason
        message: str
        error: BaseException | None = None
        tb_text: str | None = None
        failing: str | None = None
        root = self.tree.root
        try:
            if self._loaded is not None:
                self._loaded.write_blackboard_defaults()
            timeout = self.setup_timeout_s
            if threading.current_thread() is not threading.main_thread():
                # py_trees times its setup with a signal, which only the main thread
                # may set: a run in another thread (a planner's thread pool) raised
                # "signal only works in main thread"; there the setup is not timed
                timeout = py_trees.common.Duration.INFINITE.value
            self.tree.setup(timeout=timeout)
            next_s = start_s
            while True:
                now_s = self.clock.now()
                elapsed_s = now_s - start_s
                if self.max_time_s is not None and elapsed_s >= self.max_time_s:
                    reason = StopReason.TIME_LIMIT
                    message = f"time limit of {self.max_time_s:g} s reached after {ticks} ticks"
                    break
                ticks += 1
                info = TickInfo(ticks, elapsed_s, self.tree)
                for hook in self.pre_tick:
                    hook(info)
                if self.halted is not None and (halt := self.halted()) is not None:
                    held = TickInfo(ticks, elapsed_s, self.tree, root.status, 0.0)
                    for hook in self.post_tick:
                        hook(held)
                    reason, message = StopReason.FAILURE, halt
                    break
                if self.paused is not None and self.paused():
                    paused_ticks += 1
                    held = TickInfo(ticks, elapsed_s, self.tree, root.status, 0.0)
                    for hook in self.post_tick:
                        hook(held)
                    next_s += self.period_s
                    self._wait_until(next_s)
                    continue
                t0 = time.perf_counter()
                tick_tree(self.tree)
                duration = time.perf_counter() - t0
                durations_total += duration
                max_tick = max(max_tick, duration)
                if duration > self.tick_budget_s:
                    overrun_count += 1
                    if len(overruns) < self.max_overruns_kept:
                        overruns.append(Overrun(ticks, duration, self.tick_budget_s))
                status = root.status
                done = TickInfo(ticks, elapsed_s, self.tree, status, duration)
                for hook in self.post_tick:
                    hook(done)
                if status == Status.SUCCESS:
                    reason, message = StopReason.SUCCESS, f"tree succeeded after {ticks} ticks"
                    break
                if status == Status.FAILURE:
                    reason, message = StopReason.FAILURE, f"tree failed after {ticks} ticks"
                    break
                next_s += self.period_s
                self._wait_until(next_s)
        except KeyboardInterrupt as exc:
            reason, error = StopReason.INTERRUPTED, exc
            message = f"interrupted ({str(exc) or 'Ctrl-C'})"
        except _RAISED as exc:
            error = exc
            failing = _culprit(exc, root)
            tb_text = "".join(traceback.format_exception(exc))
            reason = StopReason.EXCEPTION
            where = f" in {failing}" if failing else ""
            said = said_of(exc)  # "MemoryError in s/boom", not "...: " with nothing said
            message = f"{type(exc).__name__}{where}" + (f": {said}" if said else "")
            _log.debug("run ended by an exception%s:\n%s", where, tb_text)
        stopped: tuple[str, ...] = ()
        safe_called = False
        pending: BaseException | None = None  # a Ctrl-C in a terminate(): out of run() last
        if reason is not StopReason.SUCCESS:
            stopped, pending = self._stop_running(root)
            # the first cause, for the safe-state callback (a supervisor cuts what it keeps)
            self.stop_message = message
            safe_called = self._call_safe_state()
        loop_ticks = ticks
        settle_ticks, settle_interrupted = self._come_to_rest(ticks, start_s)
        ticks += settle_ticks
        if settle_interrupted is not None and error is None:
            # a Ctrl-C while the wheels ramped down after the tree ended: the run ends
            # interrupted, the robot put in its safe state (until 2026-11-30 a success)
            reason, error = StopReason.INTERRUPTED, settle_interrupted
            message = (
                f"interrupted ({str(settle_interrupted) or 'Ctrl-C'}) as the robot came to rest"
            )
            safe_called = safe_called or self._call_safe_state()
        pending = self._shutdown() or pending
        result = RunResult(
            outcome="success" if reason is StopReason.SUCCESS else "failure",
            reason=reason,
            message=message,
            ticks=ticks,
            sim_time_s=self.clock.now() - start_s,
            wall_time_s=time.perf_counter() - wall0,
            failing_node=failing,
            error=error,
            traceback=tb_text,
            overruns=tuple(overruns),
            overrun_count=overrun_count,
            max_tick_s=max_tick,
            mean_tick_s=durations_total / loop_ticks if loop_ticks else 0.0,
            safe_state_called=safe_called,
            stopped_nodes=stopped,
            paused_ticks=paused_ticks,
            settle_ticks=settle_ticks,
        )
        for on_finish in self.finish:
            try:
                on_finish(result)
            except KeyboardInterrupt as exc:
                # Ctrl-C while the run's outputs close: the hooks after it still run (the
                # promise of a Ctrl-C in a tick), and a run without an error before ends
                # interrupted, the robot left safe; it went out of run() past them
                _log.warning("interrupted (Ctrl-C) while the run's outputs were written")
                if result.error is None:
                    result = dataclasses.replace(
                        result,
                        outcome="failure",
                        reason=StopReason.INTERRUPTED,
                        message=f"interrupted ({str(exc) or 'Ctrl-C'}) as the run ended",
                        error=exc,
                        safe_state_called=result.safe_state_called or self._call_safe_state(),
                    )
            except _RAISED as exc:
                _log.debug("finish hook failed", exc_info=True)
                if result.error is None and result.outcome != "success":
                    # a run that had failed keeps its first cause (a stall, not the
                    # hook's error after it); what the hook could not do is said
                    _log.warning(
                        "after the run failed, a finish hook raised %s",
                        f"{type(exc).__name__}" + (f": {said}" if (said := said_of(exc)) else ""),
                    )
                elif result.error is None:
                    # What the run was asked to leave behind (its trace) is not there:
                    # not a success, and the robot is left safe as after any failure.
                    result = dataclasses.replace(
                        result,
                        outcome="failure",
                        reason=StopReason.EXCEPTION,
                        message=f"{type(exc).__name__}"
                        + (f": {said}" if (said := said_of(exc)) else ""),
                        error=exc,
                        traceback="".join(traceback.format_exception(exc)),
                        safe_state_called=result.safe_state_called or self._call_safe_state(),
                    )
        if pending is not None:
            # the robot is in its safe state and the outputs are written: the Ctrl-C goes
            # on, to stop the program (it went out past the safe stop, the robot driving)
            raise RunInterrupted(result) from pending
        return result

    def _wait_until(self, when_s: float) -> None:
        delay = when_s - self.clock.now()
        if delay <= 0:
            return
        if self.realtime and self.clock.is_simulated:
            time.sleep(delay)
        self.clock.sleep(delay)

    def _stop_running(
        self, root: py_trees.behaviour.Behaviour
    ) -> tuple[tuple[str, ...], BaseException | None]:
        """Stop every RUNNING node, deepest first (py_trees leaves them running); the nodes
        stopped, and the first Ctrl-C a ``terminate()`` raised (the others still stopped)."""
        running = [n for n in root.iterate() if n.status == Status.RUNNING]
        stopped: list[str] = []
        held: BaseException | None = None
        for node in running:  # iterate() yields children before their parents
            if node.status != Status.RUNNING:
                continue  # already stopped through a parent
            try:
                node.stop(Status.INVALID)
            except BaseException as exc:
                if isinstance(exc, _RAISED):
                    _log.error(
                        "terminate() of %s raised %s: %s",
                        node_path(node),
                        type(exc).__name__,
                        said_of(exc),
                    )
                    _log.debug("terminate() raised", exc_info=True)
                else:
                    _log.warning(
                        "%s in terminate() of %s as the run ended: the robot is put in"
                        " its safe state before it goes on",
                        type(exc).__name__,
                        node_path(node),
                    )
                    held = held or exc
            stopped.append(node_path(node))
        return tuple(stopped), held

    def _come_to_rest(self, ticks: int, start_s: float) -> tuple[int, KeyboardInterrupt | None]:
        """Tick without the tree until ``settle`` says the robot is at rest; how many, and
        the Ctrl-C that cut it short (the wheels were stopped: it ends the run
        interrupted, not out of ``run()``)."""
        if self.settle is None:
            return 0, None
        root = self.tree.root
        deadline_s = self.clock.now() + self.settle_limit_s
        next_s = self.clock.now()
        n = 0
        interrupted: KeyboardInterrupt | None = None
        try:
            while not self.settle():
                if self.clock.now() >= deadline_s - 1e-9:
                    unknown = self.rest_unknown() if self.rest_unknown is not None else None
                    if unknown is not None:  # after a link loss nothing says it moves
                        _log.warning("%s", unknown)
                    else:
                        _log.warning(
                            "the robot was not at rest %.1f s after the run ended",
                            self.settle_limit_s,
                        )
                    break
                next_s += self.period_s
                self._wait_until(next_s)
                n += 1
                elapsed_s = self.clock.now() - start_s
                info = TickInfo(ticks + n, elapsed_s, self.tree)
                for hook in self.pre_tick:
                    hook(info)
                held = TickInfo(ticks + n, elapsed_s, self.tree, root.status, 0.0)
                for hook in self.post_tick:
                    hook(held)
        except KeyboardInterrupt as exc:  # a Ctrl-C while the wheels ramp down
            _log.warning("interrupted while the robot came to rest")
            interrupted = exc
        except _RAISED as exc:
            _log.error(
                "coming to rest at the end of the run: %s: %s", type(exc).__name__, said_of(exc)
            )
            _log.debug("settling raised", exc_info=True)
        return n, interrupted

    def _call_safe_state(self) -> bool:
        if self.safe_state is None:
            return False
        for attempt in range(2):
            try:
                self.safe_state()
            except KeyboardInterrupt:  # a second Ctrl-C: the stop is what it asks for
                if attempt == 0:
                    continue
                _log.error("safe-state callback interrupted twice")
                return False
            except _RAISED as exc:
                _log.error("safe-state callback raised %s: %s", type(exc).__name__, said_of(exc))
                _log.debug("safe-state callback raised", exc_info=True)
                return False
            return True
        return False

    def _shutdown(self) -> BaseException | None:
        """Shut the tree down; a Ctrl-C there is handed back, to go on once the run's
        outputs are written."""
        try:
            self.tree.shutdown()
        except _RAISED as exc:
            _log.error("tree shutdown raised %s: %s", type(exc).__name__, said_of(exc))
            _log.debug("tree shutdown raised", exc_info=True)
        except BaseException as exc:
            return exc
        return None
