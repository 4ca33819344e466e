"""Open a robot connection wrapped in its supervisor, so layers above never touch the link.

:func:`open_supervisor` is how the runner, the teleop and planner code get a
robot: it opens the link (``pirate_bt.link.open_link``) for a serial device or
pyserial URL - or the built-in simulator when no URL is given - waits for the
first state frame, and returns the :class:`~pirate_bt.safety.supervisor.Supervisor`
that owns it. Nothing above ``safety/`` imports ``pirate_bt.link``.
"""

from __future__ import annotations

import importlib
from collections.abc import Iterable
from typing import Any

from pirate_bt.clock import Clock, WallClock
from pirate_bt.errors import ConfigurationError, LinkTimeout
from pirate_bt.robot.description import RobotDescription
from pirate_bt.robot.loader import load_robot
from pirate_bt.robot.port import RobotPort
from pirate_bt.safety.operator import Mode, OperatorInput
from pirate_bt.safety.supervisor import Supervisor

__all__ = ["open_supervisor", "wait_for_state"]


def wait_for_state(port: RobotPort, clock: Clock, timeout_s: float) -> None:
    """Poll ``port`` until its first state snapshot arrives.

    Raises:
        LinkTimeout: no state within ``timeout_s`` of ``clock``.
    """
    deadline = clock.now() + timeout_s
    step = port.robot.bridge.state_period
    while port.state() is None:
        port.poll()
        if port.state() is not None:
            return
        if clock.now() >= deadline:
            raise LinkTimeout(f"no state from the robot within {timeout_s:g} s")
        clock.sleep(step)


def _simulator_url() -> str:
    # The simulator registers its own URL scheme; looked up by name so that safety
    # works (and type-checks) without it.
    sim = importlib.import_module("pirate_bt.sim")
    url = getattr(sim, "DEFAULT_URL", None) or getattr(sim, "SIM_URL", None)
    if not isinstance(url, str):
        raise ConfigurationError("the built-in simulator is not available; give a port URL")
    return url


def open_supervisor(
    robot: RobotDescription | None = None,
    *,
    url: str | None = None,
    clock: Clock | None = None,
    mode: Mode = Mode.AUTONOMOUS,
    inputs: Iterable[OperatorInput] = (),
    state_timeout_s: float = 5.0,
    **link_options: Any,
) -> Supervisor:
    """Open the robot at ``url`` (default: the built-in simulator) behind a supervisor.

    Args:
        robot: The robot description (default: the bundled 2018 robot).
        url: Serial device or pyserial URL; ``None`` for the simulator.
        clock: The clock (default: wall clock).
        mode: The mode the supervisor starts in.
        inputs: Operator input sources.
        state_timeout_s: How long to wait for the first state frame.
        **link_options: Passed to ``pirate_bt.link.open_link`` (``faults``, ``config``, ...).

    Returns:
        A supervisor holding the connected port.

    Raises:
        LinkError: cannot connect, or no state in time.
    """
    from pirate_bt.link import open_link

    robot = robot if robot is not None else load_robot()
    clock = clock if clock is not None else WallClock()
    port = open_link(url if url is not None else _simulator_url(), robot, clock, **link_options)
    try:
        wait_for_state(port, clock, state_timeout_s)
    except BaseException:
        port.close()
        raise
    return Supervisor(port, clock, mode=mode, inputs=inputs)
