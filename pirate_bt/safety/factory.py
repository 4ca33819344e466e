"""Open a robot connection wrapped in its supervisor, so layers above never touch the link.

:func:`open_supervisor` is how the runner, the teleop and planner code get a
robot: it opens the link (``pirate_bt.link.open_link``) for a serial device or
pyserial URL - or, when no URL is given, starts the built-in simulator
(:class:`pirate_bt.sim.Simulator`) in this process on a simulated clock and
reaches it through the same link (``sim://NAME``) - waits for the first state
frame, and returns the :class:`~pirate_bt.safety.supervisor.Supervisor` that owns
it. Nothing above ``safety/`` imports ``pirate_bt.link``; planner code gets a
simulated robot in one call::

    sup = open_supervisor(network="riser", seed=3)
    sup.clock.sleep(0.05)          # the simulated world moves with the clock
    sup.simulator.counters()       # the simulator's oracles
    sup.close()                    # stops the drives, closes the link and the simulator
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from pathlib import Path
from typing import TYPE_CHECKING, Any

from pirate_bt.clock import Clock, SimClock, WallClock
from pirate_bt.errors import ConfigurationError, InputError, LinkTimeout
from pirate_bt.robot.description import RobotDescription
from pirate_bt.robot.loader import load_robot
from pirate_bt.robot.port import RobotPort
from pirate_bt.safety.operator import Mode, OperatorInput
from pirate_bt.safety.supervisor import Supervisor
from pirate_bt.safety.supervisor_authority import as_mode
from pirate_bt.units import parse_quantity

if TYPE_CHECKING:
    from pirate_bt.pipes import FaultSpec, Network

__all__ = ["DEFAULT_NETWORK", "open_supervisor", "wait_for_state"]

DEFAULT_NETWORK = "straight"
"""The bundled pipe network the simulator starts in when none is given."""


def wait_for_state(port: RobotPort, clock: Clock, timeout_s: float) -> None:
    """Poll ``port`` until its first state snapshot arrives, then until every channel of
    the robot has been heard once (or ``timeout_s`` has passed since the start).

    A bridge polls its boards in turn, so its first STATE frames may carry only some
    channels fresh. Starting a run then would meet readings that were never received,
    and the protective layer would stop at once on "stale data". Waiting for one whole
    poll cycle (tens of milliseconds) avoids it; a board that never answers is not an
    error here: the supervisor names its channels stale, as it should.

    Raises:
        LinkTimeout: no state at all within ``timeout_s`` of ``clock``.
    """
    start = clock.now()
    deadline = start + timeout_s
    step = port.robot.bridge.state_period
    while port.state() is None:
        port.poll()
        if port.state() is not None:
            break
        if clock.now() >= deadline:
            health = port.health()  # frames came, none was taken; or bytes, no frame
            refused = health.states_refused_text() or health.line_noise
            why = f": {refused}" if refused else ""
            raise LinkTimeout(f"no state from the robot within {timeout_s:g} s{why}")
        clock.sleep(step)
    names = [c.name for c in port.robot.state_channels()]
    while clock.now() < deadline:
        state = port.state()
        if state is None or all(math.isfinite(state.age_s(n, clock.now())) for n in names):
            return
        clock.sleep(step)
        port.poll()


def open_supervisor(
    robot: RobotDescription | None = None,
    *,
    url: str | None = None,
    clock: Clock | None = None,
    mode: Mode = Mode.AUTONOMOUS,
    inputs: Iterable[OperatorInput] = (),
    state_timeout_s: float = 5.0,
    network: Network | str | Path | None = None,
    seed: int = 0,
    sim_faults: Iterable[FaultSpec | str] = (),
    **link_options: Any,
) -> Supervisor:
    """Open the robot at ``url`` (default: an in-process simulator) behind a supervisor.

    With ``url=None`` a :class:`pirate_bt.sim.Simulator` is started in ``network``
    on a :class:`~pirate_bt.clock.SimClock` (the world moves only when that clock
    is advanced, e.g. by ``clock.sleep``), opened through the link like any port,
    and kept as :attr:`Supervisor.simulator`; :meth:`Supervisor.close` closes it.

    Args:
        robot: The robot description (default: the bundled 2018 robot).
        url: Serial device or pyserial URL; ``None`` for the built-in simulator.
        clock: The clock (default: a new ``SimClock`` for the simulator, else the wall
            clock). The simulator needs a ``SimClock``.
        mode: The mode the supervisor starts in.
        inputs: Operator input sources.
        state_timeout_s: How long to wait for the first state frame.
        network: Simulator only: a pipe network, a file or a bundled name (default
            :data:`DEFAULT_NETWORK`).
        seed: Simulator only: its random seed.
        sim_faults: Simulator only: faults it injects (``"board_reset:22@10s"``).
        **link_options: Passed to ``pirate_bt.link.open_link`` (``faults``, ``config``, ...).

    Returns:
        A supervisor holding the connected port.

    Raises:
        InputError: a mode that is none, or a ``state_timeout_s`` that is no finite
            time (seconds, or text: ``"5 s"``); checked before anything opens.
        ConfigurationError: simulator options with a ``url``, or the simulator on a
            clock that is not a ``SimClock``.
        LinkError: cannot connect, or no state in time.
    """
    from pirate_bt.link import open_link

    # before anything opens: a mode that is none was refused by the Supervisor after the
    # port (a robot's serial port) had been opened, and left it open; a NaN timeout
    # waited for the first state for ever
    mode = as_mode(mode)
    try:
        state_timeout_s = parse_quantity(state_timeout_s, "time", require_unit=False)
    except InputError as exc:
        raise InputError(f"state_timeout_s: {exc}"[:200]) from None
    if state_timeout_s < 0:
        raise InputError(f"state_timeout_s: {state_timeout_s:g} s is negative")
    robot = robot if robot is not None else load_robot()
    if url is not None:
        if network is not None or seed != 0 or tuple(sim_faults):
            raise ConfigurationError("network, seed and sim_faults apply to the simulator only")
        clock = clock if clock is not None else WallClock()
        port = open_link(url, robot, clock, **link_options)
        try:
            wait_for_state(port, clock, state_timeout_s)
        except BaseException:
            port.close()
            raise
        return Supervisor(port, clock, mode=mode, inputs=inputs)

    from pirate_bt.sim import Simulator

    clock = clock if clock is not None else SimClock()
    if not isinstance(clock, SimClock):
        raise ConfigurationError(
            "the built-in simulator runs on a SimClock; pass one (or none) or give a port URL"
        )
    sim = Simulator(
        network if network is not None else DEFAULT_NETWORK,
        robot,
        seed=seed,
        clock=clock,
        faults=sim_faults,
    )
    try:
        port = open_link(sim.url, robot, clock, **link_options)
        try:
            wait_for_state(port, clock, state_timeout_s)
        except BaseException:
            port.close()
            raise
    except BaseException:
        sim.close()
        raise
    sup = Supervisor(port, clock, mode=mode, inputs=inputs)
    sup.attach_simulator(sim)
    return sup
