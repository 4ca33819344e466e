"""Session 22: the first cause of a failed run survives a finish hook of planner code
(attached through observe=) that raises as the run ends (docs/api.md)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

import pirate_bt

STALL = "motor_stall:bend_3_drive@1s+20s"


def _finish_raises(runner: Any, connection: Any) -> None:
    def hook(result: Any) -> None:
        raise RuntimeError("my report could not be written")

    runner.add_finish(hook)


def test_a_finish_hook_that_raises_after_a_stall_keeps_the_stall_as_the_first_cause() -> None:
    # was: why 'RuntimeError: my report could not be written', the stall lost
    result = pirate_bt.simulate_tree(
        "straight", params={"distance": "0.3 m"}, faults=STALL, observe=_finish_raises
    )
    assert not result.succeeded and result.safe_state
    assert result.why.startswith("stall: bend_3_drive draws"), result.why
    assert result.error is None and result.exit_code == 1


def test_a_finish_hook_that_raises_after_a_success_still_fails_the_run() -> None:
    result = pirate_bt.simulate_tree(
        "straight", params={"distance": "0.05 m"}, observe=_finish_raises
    )
    assert not result.succeeded and result.safe_state
    assert result.why == "RuntimeError: my report could not be written"


def test_an_observe_that_closes_its_connection_is_refused_before_the_run(tmp_path: Path) -> None:
    # was a run that went on, a failure 'link lost: session closed', exit 3 (a link
    # error, the link fine), and its trace left behind
    trace = tmp_path / "t.jsonl"
    with pirate_bt.connect() as robot, pytest.raises(pirate_bt.InputError) as caught:
        robot.run(
            "straight",
            params={"distance": "0.05 m"},
            trace=trace,
            observe=lambda runner, connection: connection.close(),
        )
    assert str(caught.value) == (
        "observe: it closed the connection (simulator: straight) before the run; close it"
        " once the run has ended (or use with pirate_bt.connect() as robot:)"
    )
    assert not trace.exists()


def test_a_connection_closed_during_its_run_says_so_first() -> None:
    import threading

    def close_at_tick_20(runner: Any, connection: Any) -> None:
        ticks = [0]

        def hook(info: Any) -> None:
            ticks[0] += 1
            if ticks[0] == 20:  # another thread of the planner's closes it mid-run
                closer = threading.Thread(target=connection.close)
                closer.start()
                closer.join(timeout=30)

        runner.add_post_tick(hook)

    # was 'link lost: session closed' alone: a link error, where planner code closed it
    with pirate_bt.connect() as robot:
        result = robot.run("straight", params={"distance": "0.3 m"}, observe=close_at_tick_20)
    assert not result.succeeded
    assert result.why == (
        "the connection (simulator: straight) was closed during the run: link lost: session closed"
    )
