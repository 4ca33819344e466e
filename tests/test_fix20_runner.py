"""The runner's and the API's leftovers of the twentieth session: a Ctrl-C in a node's
terminate() as the run ends, what is said after a link loss, a supervised run with no
operator, and reasons of any length."""

from __future__ import annotations

import logging
import types
from pathlib import Path
from typing import Any

import py_trees
import pytest
from py_trees.common import Status

from pirate_bt.clock import SimClock
from pirate_bt.runner import Runner, RunResult, StopReason


class _Moving(py_trees.behaviour.Behaviour):
    """Runs forever; records how it was stopped."""

    def __init__(self, name: str) -> None:
        super().__init__(name)
        self.stopped_with: Status | None = None

    def update(self) -> Status:
        return Status.RUNNING

    def terminate(self, new_status: Status) -> None:
        self.stopped_with = new_status


class _CtrlCWhenStopped(py_trees.behaviour.Behaviour):
    """Runs forever; Ctrl-C lands in its terminate() when the runner stops it."""

    def update(self) -> Status:
        return Status.RUNNING

    def terminate(self, new_status: Status) -> None:
        if new_status == Status.INVALID:
            raise KeyboardInterrupt


def test_a_ctrl_c_in_terminate_as_the_run_ends_goes_on_only_once_the_robot_is_safe() -> None:
    # a Runner used directly (as the missions use it): the Ctrl-C went out of run() from
    # the first terminate(), the drive beside it never stopped, no safe state called and
    # the trace never ended; only the API's Connection.run made the robot safe
    interrupted = _CtrlCWhenStopped("watch")
    drive = _Moving("drive")
    root = py_trees.composites.Parallel(
        "both", py_trees.common.ParallelPolicy.SuccessOnAll(), [interrupted, drive]
    )
    clock = SimClock()
    runner = Runner(root, clock=clock, period_s=0.05, max_time_s=0.2)
    safe: list[str | None] = []
    runner.safe_state = lambda: safe.append(runner.stop_message)
    finished: list[RunResult] = []
    runner.add_finish(finished.append)
    with pytest.raises(KeyboardInterrupt):
        runner.run()
    assert drive.stopped_with == Status.INVALID
    assert safe == ["time limit of 0.2 s reached after 4 ticks"]  # the first cause
    assert [r.reason for r in finished] == [StopReason.TIME_LIMIT]
    assert finished[0].safe_state_called
    assert finished[0].stopped_nodes == ("both/watch", "both/drive", "both")


class _Raises(py_trees.behaviour.Behaviour):
    """Raises an exception with a 100 kB message on its first tick."""

    def update(self) -> Status:
        raise RuntimeError("x" * 100_000)


def test_a_100_kb_exception_message_is_cut_in_the_safe_state_and_kept_in_the_result() -> None:
    # the whole 100 kB went into the safe-state reason, and from there into the trace's
    # verdicts, the log and the next run's refusal; the result's message keeps it whole
    # (the trace's end record, Trace.why), the API's why leaves its middle out
    import pirate_bt

    with pirate_bt.connect("sim:straight") as robot:
        result = robot.run(_Raises("boom"))
        reason = robot.supervisor.safe_state_reason or ""
    assert result.status == "failure" and len(result.why) <= 1100
    assert len(reason) <= 1000
    # its start (the node) and its end kept, the middle left out and counted once
    kept, _, left = reason.partition("...(")
    assert kept.startswith("tree run ended without success: RuntimeError in boom: xxx")
    count, _, tail = left.partition(" characters)...")
    assert "characters)" not in tail and tail.endswith("x")
    whole = "tree run ended without success: RuntimeError in boom: " + "x" * 100_000
    assert len(kept) + int(count) + len(tail) == len(whole)
    runner = Runner(_Raises("boom"), clock=SimClock())
    assert runner.run().message == "RuntimeError in boom: " + "x" * 100_000


class _FailsWithALongWord(py_trees.behaviour.Behaviour):
    """Fails on its first tick, its feedback 100 kB long."""

    def update(self) -> Status:
        self.feedback_message = "no way through: " + "y" * 100_000
        return Status.FAILURE


def test_a_long_failure_cause_is_cut_in_the_connection_s_safe_state_reason() -> None:
    import pirate_bt

    with pirate_bt.connect("sim:straight") as robot:
        result = robot.run(_FailsWithALongWord("probe"))
        reason = robot.supervisor.safe_state_reason or ""
    assert result.status == "failure"
    assert reason.startswith("tree run ended without success: no way through: yyy")
    assert len(reason) <= 1100 and " characters)...yyy" in reason


_STEEP = """schema_version: 1
name: steep
diameter: 63 mm
slope: 90 deg
segments:
  - {id: up, type: straight, length: 2 m}
"""


def test_after_a_link_loss_the_end_of_a_run_does_not_say_the_robot_was_not_at_rest(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    # a protective clamp was on its way in a vertical pipe when the link was lost: the end
    # of the run said "the robot was not at rest 2.0 s after the run ended", which nothing
    # heard from the robot could say; the robot's state is unknown
    import pirate_bt

    network = tmp_path / "steep.yaml"
    network.write_text(_STEEP, encoding="utf-8")
    caplog.set_level(logging.WARNING, logger="pirate_bt.runner")
    with pirate_bt.connect(str(network), faults="link_loss@2s") as robot:
        result = robot.run("straight", params={"distance": "0.3 m"}, max_time="10 s")
    assert result.status == "failure" and result.why.startswith("link_silent: ")
    said = [r.getMessage() for r in caplog.records if r.name == "pirate_bt.runner"]
    assert said == [
        "the link is lost: the robot's state at the end of the run is unknown"
        " (the bridge's watchdog stops its motors)"
    ]


class _LinkLost:
    """A supervisor as the end of a run sees it once the link is lost."""

    run_halted = None

    def tick(self) -> None:
        pass

    def end_safe(self, reason: str) -> None:
        pass

    def come_to_rest(self) -> bool:
        return False  # a protective clamp still landing, as far as anyone knows

    def health(self) -> Any:
        return types.SimpleNamespace(connected=False)


def test_a_mission_s_runner_says_the_same_after_a_link_loss(
    caplog: pytest.LogCaptureFixture,
) -> None:
    caplog.set_level(logging.WARNING, logger="pirate_bt.runner")
    runner = Runner.supervised(
        _Moving("drive"), _LinkLost(), clock=SimClock(), end_reason=lambda: "x", max_time_s=0.1
    )
    runner.run()
    said = [r.getMessage() for r in caplog.records if r.name == "pirate_bt.runner"]
    assert said == [
        "the link is lost: the robot's state at the end of the run is unknown"
        " (the bridge's watchdog stops its motors)"
    ]


def test_a_supervised_run_with_no_operator_fails_at_its_first_confirmation() -> None:
    # nobody attached could ever confirm the step: the run waited out its whole time
    # limit (600 s by default, in wall time on a robot) before it failed
    import pirate_bt

    with pirate_bt.connect("sim:straight", mode="supervised") as robot:
        result = robot.run("straight", params={"distance": "0.3 m"}, max_time="60 s")
    assert result.status == "failure" and result.sim_time_s < 1.0
    assert result.why == (
        "straight/pass straight/hold or over an opening/hold waits for an operator to"
        " confirm 'hold the pipe with both halves' (supervised mode), and no operator"
        " input is attached: attach one (supervisor.add_input) or run in autonomous mode"
    )


def test_a_runner_of_your_own_still_waits_for_confirmations_given_through_the_supervisor() -> None:
    # the operator console confirms through the supervisor (y), attaching no input: its
    # robot.runner(...) must not end at the first step it asks for
    import pirate_bt

    with pirate_bt.connect("sim:straight", mode="supervised") as robot:
        runner = robot.runner("straight", params={"distance": "0.1 m"}, max_time="30 s")
        sup = robot.supervisor

        def key_y_now_and_then(info: Any) -> None:
            if info.tick % 10 == 0 and sup.pending_confirmations():
                sup.confirm()

        runner.add_pre_tick(key_y_now_and_then)
        loop = runner.run()
    assert loop.succeeded, loop.message
