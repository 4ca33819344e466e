"""The runner: rate, stop conditions, exception safety, Ctrl-C, hooks and tick budget."""

from __future__ import annotations

import py_trees
import pytest
from py_trees.common import Status

from pirate_bt.clock import SimClock
from pirate_bt.runner import Runner, StopReason, TickInfo


class Motion(py_trees.behaviour.Behaviour):
    """Runs forever; records whether terminate() cancelled it."""

    def __init__(self, name: str) -> None:
        super().__init__(name)
        self.terminated_with: Status | None = None

    def update(self) -> Status:
        return Status.RUNNING

    def terminate(self, new_status: Status) -> None:
        self.terminated_with = new_status


class Boom(py_trees.behaviour.Behaviour):
    """Raises on its n-th tick (or KeyboardInterrupt with ``interrupt``)."""

    def __init__(self, name: str, on_tick: int, interrupt: bool = False) -> None:
        super().__init__(name)
        self.count = 0
        self.on_tick = on_tick
        self.interrupt = interrupt

    def update(self) -> Status:
        self.count += 1
        if self.count >= self.on_tick:
            if self.interrupt:
                raise KeyboardInterrupt
            raise ValueError("sensor exploded")
        return Status.RUNNING


def _tree(boom: py_trees.behaviour.Behaviour) -> tuple[py_trees.behaviour.Behaviour, Motion]:
    motion = Motion("drive")
    work = py_trees.composites.Parallel(
        "work", py_trees.common.ParallelPolicy.SuccessOnAll(), [motion, boom]
    )
    return py_trees.composites.Sequence("mission", True, [work]), motion


def test_an_exception_stops_running_nodes_and_calls_the_safe_state() -> None:
    root, motion = _tree(Boom("check", on_tick=3))
    safe: list[str] = []
    result = Runner(root, clock=SimClock(), safe_state=lambda: safe.append("safe")).run()
    assert result.outcome == "failure"
    assert result.reason is StopReason.EXCEPTION
    assert result.failing_node == "mission/work/check"
    assert "sensor exploded" in (result.traceback or "")
    assert isinstance(result.error, ValueError)
    assert motion.terminated_with == Status.INVALID
    assert "mission/work/drive" in result.stopped_nodes
    assert all(n.status != Status.RUNNING for n in root.iterate())
    assert safe == ["safe"] and result.safe_state_called
    assert result.ticks == 3


def test_ctrl_c_ends_in_the_safe_state_and_runs_finish_hooks() -> None:
    root, motion = _tree(Boom("check", on_tick=2, interrupt=True))
    safe: list[str] = []
    finished = []
    runner = Runner(root, clock=SimClock(), safe_state=lambda: safe.append("safe"))
    runner.add_finish(finished.append)
    result = runner.run()
    assert result.reason is StopReason.INTERRUPTED and result.outcome == "failure"
    assert motion.terminated_with == Status.INVALID
    assert safe == ["safe"]
    assert finished == [result]


def test_ctrl_c_in_a_finish_hook_still_runs_the_others_and_ends_interrupted() -> None:
    # a Ctrl-C while a step's trace closed went out of run() past the hooks after it
    # (a survey lost its navigation record's end and its file)
    root = py_trees.behaviours.Success(name="done")
    safe: list[str] = []
    finished: list[object] = []

    def interrupted(result: object) -> None:
        raise KeyboardInterrupt

    runner = Runner(root, clock=SimClock(), safe_state=lambda: safe.append("safe"))
    runner.add_finish(interrupted)
    runner.add_finish(finished.append)
    result = runner.run()
    assert result.reason is StopReason.INTERRUPTED and result.outcome == "failure"
    assert result.message == "interrupted (Ctrl-C) as the run ended"
    assert safe == ["safe"] and result.safe_state_called
    assert len(finished) == 1  # the hook after it ran


class _Ramping:
    """A robot whose wheels ramp down for ever after the run, and a Ctrl-C on the second
    tick of that: ``settle`` for the runner, ``interrupt`` for its post-tick hooks."""

    def __init__(self) -> None:
        self.asked = 0
        self.interrupted = False

    def settle(self) -> bool:
        self.asked += 1
        return False

    def interrupt(self, info: object) -> None:
        if self.asked == 2 and not self.interrupted:
            self.interrupted = True
            raise KeyboardInterrupt


def test_ctrl_c_while_the_robot_comes_to_rest_after_a_success_ends_interrupted() -> None:
    # the tree succeeded and the wheels ramp down; a Ctrl-C then was only logged and the
    # run said success (exit 0), its robot not put in its safe state
    root = py_trees.behaviours.Success(name="done")
    safe: list[str] = []
    ramping = _Ramping()
    runner = Runner(
        root, clock=SimClock(), safe_state=lambda: safe.append("safe"), settle=ramping.settle
    )
    runner.add_post_tick(ramping.interrupt)
    result = runner.run()
    assert ramping.interrupted
    assert result.reason is StopReason.INTERRUPTED and result.outcome == "failure"
    assert result.message == "interrupted (Ctrl-C) as the robot came to rest"
    assert isinstance(result.error, KeyboardInterrupt)
    assert safe == ["safe"] and result.safe_state_called


def test_ctrl_c_while_coming_to_rest_after_a_failure_keeps_the_first_cause() -> None:
    root, _ = _tree(Boom("check", on_tick=2))
    safe: list[str] = []
    ramping = _Ramping()
    runner = Runner(
        root, clock=SimClock(), safe_state=lambda: safe.append("safe"), settle=ramping.settle
    )
    runner.add_post_tick(ramping.interrupt)
    result = runner.run()
    assert ramping.interrupted
    assert result.reason is StopReason.EXCEPTION and "sensor exploded" in result.message
    assert safe == ["safe"]


def test_ctrl_c_while_waiting_between_ticks() -> None:
    class Interrupting(SimClock):
        def sleep(self, seconds: float) -> None:
            raise KeyboardInterrupt

    root, motion = _tree(Boom("check", on_tick=99))
    safe: list[str] = []
    result = Runner(root, clock=Interrupting(), safe_state=lambda: safe.append("safe")).run()
    assert result.reason is StopReason.INTERRUPTED
    assert motion.terminated_with == Status.INVALID and safe == ["safe"]


def test_time_limit_on_the_simulated_clock() -> None:
    clock = SimClock()
    motion = Motion("drive")
    safe: list[str] = []
    result = Runner(
        motion, clock=clock, period_s=0.1, max_time_s=2.0, safe_state=lambda: safe.append("x")
    ).run()
    assert result.reason is StopReason.TIME_LIMIT
    assert result.ticks == 20
    assert abs(result.sim_time_s - 2.0) < 1e-9
    assert motion.terminated_with == Status.INVALID and safe == ["x"]


def test_success_does_not_call_the_safe_state_and_hooks_see_every_tick() -> None:
    clock = SimClock()
    queue = py_trees.behaviours.StatusQueue(
        "q", [Status.RUNNING, Status.RUNNING, Status.SUCCESS], Status.SUCCESS
    )
    seen_pre: list[TickInfo] = []
    seen_post: list[TickInfo] = []
    safe: list[str] = []
    runner = Runner(queue, clock=clock, period_s=0.5, safe_state=lambda: safe.append("x"))
    runner.add_pre_tick(seen_pre.append)
    runner.add_post_tick(seen_post.append)
    result = runner.run()
    assert result.succeeded and result.reason is StopReason.SUCCESS
    assert [i.tick for i in seen_pre] == [1, 2, 3]
    assert [i.time_s for i in seen_post] == [0.0, 0.5, 1.0]
    assert [i.status for i in seen_post] == [Status.RUNNING, Status.RUNNING, Status.SUCCESS]
    assert all(i.status is None for i in seen_pre)
    assert safe == []


def test_a_failing_hook_is_handled_like_a_failing_behaviour() -> None:
    def broken(_info: TickInfo) -> None:
        raise ConnectionError("link gone")

    motion = Motion("drive")
    runner = Runner(motion, clock=SimClock(), safe_state=lambda: None)
    runner.add_pre_tick(broken)
    result = runner.run()
    assert result.reason is StopReason.EXCEPTION and result.failing_node is None
    assert result.safe_state_called


def test_tick_overruns_are_reported() -> None:
    clock = SimClock()
    queue = py_trees.behaviours.StatusQueue("q", [Status.RUNNING] * 3, Status.SUCCESS)
    result = Runner(queue, clock=clock, period_s=0.1, tick_budget_s=0.0).run()
    assert result.overrun_count == result.ticks == 4
    assert result.overruns[0].tick == 1 and result.max_tick_s > 0


def test_a_safe_state_that_raises_still_ends_the_run() -> None:
    def bad() -> None:
        raise RuntimeError("cannot")

    result = Runner(Motion("m"), clock=SimClock(), max_time_s=0.2, safe_state=bad).run()
    assert result.outcome == "failure" and not result.safe_state_called


def test_run_cli_runs_a_tree_of_generic_leaves(tmp_path: object) -> None:
    from pathlib import Path

    from pirate_bt.cli import main

    folder = Path(str(tmp_path))
    ok = folder / "ok.yaml"
    ok.write_text("root: {type: wait, duration: 2 s}\n", encoding="utf-8")
    assert main(["run", str(ok)]) == 0
    bad = folder / "bad.yaml"
    bad.write_text("root: failure\n", encoding="utf-8")
    assert main(["run", str(bad)]) == 1
    slow = folder / "slow.yaml"
    slow.write_text("root: {type: wait, duration: 1 h}\n", encoding="utf-8")
    assert main(["run", str(slow), "--max-time", "10 s"]) == 1


def test_a_paused_tree_is_not_ticked_but_hooks_still_run() -> None:
    """An operator in MANUAL pauses the tree: no tick reaches it, time still passes."""
    counter = py_trees.behaviours.TickCounter("count", duration=3, completion_status=Status.SUCCESS)
    paused_at = {2, 3, 4}
    seen: list[tuple[int, Status]] = []
    clock = SimClock()
    runner = Runner(counter, clock=clock, period_s=0.1, paused=lambda: len(seen) + 1 in paused_at)
    runner.add_post_tick(lambda info: seen.append((info.tick, info.status)))
    result = runner.run()
    assert result.succeeded
    assert result.paused_ticks == 3
    # TickCounter(duration=3) needs 4 ticks of work; ticks 2-4 were held, so 7 in all.
    assert result.ticks == 7
    assert counter.counter == 4  # ticked only when not paused
    assert [s for _, s in seen] == [Status.RUNNING] * 6 + [Status.SUCCESS]
    assert result.sim_time_s == pytest.approx(0.6)


class _Log(py_trees.visitors.VisitorBase):
    """A visitor that writes down everything py_trees shows it."""

    def __init__(self, log: list[tuple[object, ...]], tag: str, full: bool) -> None:
        super().__init__(full=full)
        self.log, self.tag = log, tag

    def initialise(self) -> None:
        self.log.append((self.tag, "initialise"))

    def run(self, behaviour: py_trees.behaviour.Behaviour) -> None:
        self.log.append((self.tag, behaviour.name, behaviour.status.value))

    def finalise(self) -> None:
        self.log.append((self.tag, "finalise"))


def _selector_tree() -> py_trees.behaviour.Behaviour:
    from py_trees.behaviours import StatusQueue

    R, S, F = Status.RUNNING, Status.SUCCESS, Status.FAILURE
    first = StatusQueue("first", [F, F, R, R, S], S)
    later = StatusQueue("later", [R, R, R, S], S)
    pick = py_trees.composites.Selector("pick", memory=False, children=[first, later])
    check = StatusQueue("check", [R, S], S)
    return py_trees.composites.Sequence("root", memory=True, children=[pick, check])


def _watched(log: list[tuple[object, ...]]) -> py_trees.trees.BehaviourTree:
    tree = py_trees.trees.BehaviourTree(_selector_tree())
    tree.visitors.append(_Log(log, "partial", full=False))
    tree.visitors.append(_Log(log, "full", full=True))
    tree.add_pre_tick_handler(lambda t: log.append(("pre", t.count)))
    tree.add_post_tick_handler(lambda t: log.append(("post", t.count, t.root.status.value)))
    return tree


def test_visitors_and_handlers_see_what_behaviour_tree_tick_shows_them() -> None:
    """The runner ticks the active path only, yet a user's visitors see no difference."""
    expected: list[tuple[object, ...]] = []
    plain = _watched(expected)
    plain.setup()
    while plain.root.status not in (Status.SUCCESS, Status.FAILURE):
        plain.tick()
    seen: list[tuple[object, ...]] = []
    watched = _watched(seen)
    result = Runner(watched, clock=SimClock(), period_s=0.05).run()
    assert result.succeeded and result.ticks == plain.count
    assert seen == expected
    assert watched.count == plain.count
    assert any(entry[0] == "full" and entry[1] == "later" for entry in seen)


def test_the_runner_does_not_walk_idle_nodes() -> None:
    """Without a full visitor, a tick touches only the nodes that run."""
    walked: list[int] = []

    class Counting(py_trees.composites.Sequence):
        def iterate(self, direct_descendants: bool = False):  # type: ignore[no-untyped-def]
            walked.append(1)
            return super().iterate(direct_descendants)

    idle = [py_trees.behaviours.Success(f"idle {i}") for i in range(50)]
    root = Counting("root", memory=True, children=[py_trees.behaviours.Running("busy"), *idle])
    runner = Runner(root, clock=SimClock(), period_s=0.05, max_time_s=1.0)
    during: list[int] = []
    runner.add_post_tick(lambda _info: during.append(len(walked)))
    runner.run()
    assert len(during) == 20
    # Set-up walks the tree once; py_trees' BehaviourTree.tick() would walk it every tick.
    assert during[0] == during[-1]


class _Exits(py_trees.behaviour.Behaviour):
    """Raises ``kind`` from ``where`` (``update`` or ``terminate``) on its 2nd tick."""

    def __init__(self, name: str, kind: type[BaseException], where: str = "update") -> None:
        super().__init__(name)
        self.kind, self.where, self.count = kind, where, 0

    def update(self) -> Status:
        self.count += 1
        if self.where == "update" and self.count >= 2:
            raise self.kind("leaving")
        if self.where == "terminate" and self.count >= 2:
            raise ValueError("failed first")
        return Status.RUNNING

    def terminate(self, new_status: Status) -> None:
        if self.where == "terminate" and new_status == Status.INVALID:
            raise self.kind("not stopping")


@pytest.mark.parametrize("kind", [SystemExit, GeneratorExit])
def test_a_node_that_exits_ends_the_run_in_the_safe_state_naming_it(
    kind: type[BaseException],
) -> None:
    # a sys.exit() in a planner's behaviour went out of Runner.run past the safe stop,
    # the drives still set (probe of 2026-11-30)
    root, motion = _tree(_Exits("leaver", kind))
    safe: list[str] = []
    result = Runner(root, clock=SimClock(), safe_state=lambda: safe.append("safe")).run()
    assert result.reason is StopReason.EXCEPTION and result.failing_node == "mission/work/leaver"
    assert result.message == f"{kind.__name__} in mission/work/leaver: leaving"
    assert safe == ["safe"] and motion.terminated_with == Status.INVALID


def test_a_terminate_that_exits_still_leaves_the_robot_safe() -> None:
    root, _ = _tree(_Exits("leaver", SystemExit, "terminate"))
    safe: list[str] = []
    result = Runner(root, clock=SimClock(), safe_state=lambda: safe.append("safe")).run()
    assert result.message == "ValueError in mission/work/leaver: failed first"
    assert safe == ["safe"]


def test_a_hook_that_exits_and_an_error_that_cannot_be_said_end_the_run_safe() -> None:
    class Unsayable(RuntimeError):
        def __str__(self) -> str:
            raise TypeError("no words")

    def finish(_result: object) -> None:
        raise SystemExit(2)

    # a run that succeeded (a failed one keeps its first cause: test_api22_first_cause.py)
    runner = Runner(
        py_trees.behaviours.Success(name="done"), clock=SimClock(), safe_state=lambda: None
    )
    runner.add_finish(finish)
    result = runner.run()
    assert result.outcome == "failure" and result.message == "SystemExit: 2"

    def pre(_info: TickInfo) -> None:
        raise Unsayable()

    root, _ = _tree(Boom("check", on_tick=99))
    runner = Runner(root, clock=SimClock(), safe_state=lambda: None)
    runner.add_pre_tick(pre)
    result = runner.run()
    assert result.message == ("Unsayable: <its message cannot be shown: Unsayable.__str__ raised>")


class _SlowSetup(py_trees.behaviour.Behaviour):
    """Takes ``seconds`` of wall time to set up, then succeeds at once."""

    def __init__(self, seconds: float) -> None:
        super().__init__("slow setup")
        self.seconds = seconds

    def setup(self, **kwargs: object) -> None:
        import time

        time.sleep(self.seconds)

    def update(self) -> Status:
        return Status.SUCCESS


def test_a_run_in_another_thread_sets_up_and_runs() -> None:
    # py_trees times a tree's setup with a signal, which only the main thread may set:
    # a run in a planner's thread (simulate_tree in a thread pool) ended at once with
    # "ValueError: signal only works in main thread of the main interpreter"
    import threading

    out: list[object] = []

    def run() -> None:
        out.append(Runner(_SlowSetup(0.0), clock=SimClock(), setup_timeout_s=5.0).run())

    thread = threading.Thread(target=run)
    thread.start()
    thread.join()
    (result,) = out
    assert result.reason is StopReason.SUCCESS, result  # type: ignore[attr-defined]


def test_a_setup_in_the_main_thread_is_still_timed() -> None:
    result = Runner(_SlowSetup(0.5), clock=SimClock(), setup_timeout_s=0.05).run()
    assert result.reason is StopReason.EXCEPTION
    assert "tree setup interrupted or timed out" in result.message, result.message


def test_an_exception_with_nothing_to_say_ends_its_message_with_where() -> None:
    # a bare MemoryError() read "MemoryError in boom: ", a colon before nothing
    class Bare(py_trees.behaviour.Behaviour):
        def update(self) -> Status:
            raise MemoryError

    result = Runner(Bare("boom"), clock=SimClock()).run()
    assert result.reason is StopReason.EXCEPTION
    assert result.message == "MemoryError in boom"
