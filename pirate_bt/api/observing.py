"""Planner code around a run (an ``observe=`` callback, its nodes' ``terminate``), and
what is made safe or undone when it raises."""

from __future__ import annotations

from typing import Any

from pirate_bt.trace.attach import call_observer

__all__ = ["call_observer", "run_to_rest"]


def run_to_rest(runner: Any, supervisor: Any) -> Any:
    """``runner.run()``; an exception the runner lets out (a ``KeyboardInterrupt``, Ctrl-C,
    raised in a node's ``terminate()`` as the runner stops the running nodes) first puts
    the robot in its safe state, then goes on. It went out with the robot driving, no
    safe state entered, to planner code that caught it inside ``with connect(...)``.
    """
    try:
        return runner.run()
    except BaseException as exc:
        if supervisor is not None:
            what = "interrupted (Ctrl-C)" if isinstance(exc, KeyboardInterrupt) else "stopped"
            supervisor.safe_state(
                f"{what}: {type(exc).__name__} raised while the run ended, out of the runner"
            )
        raise
