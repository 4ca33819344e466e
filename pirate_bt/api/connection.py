"""``connect(target)``: a supervised robot, real or simulated, its clock and a runner.

Everything a planner runs reaches the robot through this one door, and only
through the protective layer (:func:`pirate_bt.safety.factory.open_supervisor`
opens the link itself). The target says where the robot is:

- ``"sim"`` or ``"sim:NETWORK"`` - the built-in simulator in a pipe network (a
  bundled name such as ``"lab"`` or a file), on a simulated clock;
- a network file (``"scenarios/bend-right.yaml"``), a loaded ``Network`` or a
  ``NetworkSpec`` - the same;
- ``"firmware:NETWORK"`` (or a simulator target with ``firmware=True``) - the same
  pipe physics behind the real firmwares: the bridge and one reference PICO board
  per board id, each its own ELF in simavr, on one simulated RS485 line, in virtual
  time (docs/firmware-sim.md, *The whole chain*; needs ``make firmware``);
- a pyserial URL or port (``"/dev/ttyACM0"``, ``"COM3"``, ``"socket://host:7000"``,
  ``"rfc2217://..."``) - a real PIRATEbay bridge, on the wall clock.

Faults are written as on the command line: simulator faults
``KIND[:TARGET]@AT[+DURATION]`` (``"motor_stall:bend_3_drive@5s+20s"``) and link
faults ``KEY=VALUE`` (``"drop=0.05,corrupt=0.01"``), comma-separated.
"""

from __future__ import annotations

import functools
import logging
import threading
import weakref
from collections.abc import Callable, Iterable, Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from types import TracebackType
from typing import TYPE_CHECKING, Any

from pirate_bt.api.options import (
    fault_list,
    flag,
    load_robot_like,
    network_name,
    parse_target,
    seed_value,
    split_faults,
)
from pirate_bt.api.process_run import only_run
from pirate_bt.api.running import as_loaded, run_on
from pirate_bt.clock import Clock, SimClock, WallClock
from pirate_bt.errors import InputError, LinkError

if TYPE_CHECKING:
    from pirate_bt.api.results import RunResult
    from pirate_bt.behaviours.base import BuildContext
    from pirate_bt.robot.description import RobotDescription
    from pirate_bt.runner import Runner
    from pirate_bt.safety.tally import Counters

__all__ = ["Connection", "connect"]

_log = logging.getLogger("pirate_bt.api")


class Connection:
    """A robot behind its supervisor, with the clock every run on it reads.

    Made by :func:`connect`; use it as a context manager so the link closes (and the
    robot is left in its safe state if anything went wrong) whatever happens::

        with pirate_bt.connect("sim:bend-right") as robot:
            result = robot.run("trees/bend.yaml", params={"roll": "90 deg"})
            print(result.why)

    Attributes:
        robot: The robot description.
        clock: The clock trees on this connection read (simulated on the simulator).
        supervisor: The protective layer, the only road to the robot.
        simulated: True on the built-in simulator.
        target: What was connected to (a network name or a port URL).
        seed: The simulator's seed (``None`` on a real robot).
        description: One line for people (``simulator: bend-right``).
        tally: Counts the supervisor's verdicts and the link's figures since the
            connection opened (:meth:`counters`).
    """

    def __init__(
        self,
        robot: RobotDescription,
        clock: Clock,
        supervisor: Any,
        *,
        simulated: bool,
        target: str,
        seed: int | None,
        description: str,
        simulator: Any = None,
    ) -> None:
        self._simulator = simulator
        self.robot = robot
        self.clock = clock
        self.supervisor = supervisor
        self.simulated = simulated
        self.target = target
        self.seed = seed
        self.description = description
        self._closed = False
        self._running = threading.Lock()
        self.close_error: LinkError | None = None
        """Set by :meth:`close` when the link could not make sure the robot stopped (its
        closing stop and the e-stop after it never acknowledged)."""
        from pirate_bt.safety.tally import VerdictTally

        self.tally = VerdictTally(supervisor, from_open=True)
        # a connection never closed kept its in-process simulator registered (sim://NAME)
        # for the life of the process (~200 kB a run of a loop of connect() without
        # close()), its firmware chain's simavr process running. Once nothing holds the
        # supervisor (a runner of runner() keeps it), the simulator is let go.
        let_go = getattr(simulator or getattr(supervisor, "simulator", None), "close", None)
        if callable(let_go):
            weakref.finalize(supervisor, let_go)

    @property
    def simulator(self) -> Any:
        """The in-process simulator behind the supervisor (``None`` on a real robot).

        Through the firmware chain: a :class:`~pirate_bt.sim.chain_open.ChainSimulator`
        (the physics' truth and counters, and the chain's ``figures()``)."""
        if self._simulator is not None:
            return self._simulator
        return getattr(self.supervisor, "simulator", None)

    def context(self) -> BuildContext:
        """The :class:`~pirate_bt.behaviours.BuildContext` for behaviours built in Python
        on this connection (its robot, clock and supervisor)."""
        from pirate_bt.behaviours.base import BuildContext

        return BuildContext(robot=self.robot, clock=self.clock, supervisor=self.supervisor)

    def load_tree(self, tree: Any, *, params: Mapping[str, Any] | None = None) -> Any:
        """Load and check a tree for this connection (a path, a bundled name, a mapping).

        Raises:
            ValidationFailed: the tree does not validate against this robot.
        """
        return as_loaded(tree, self.robot, params)

    @property
    def closed(self) -> bool:
        """True once :meth:`close` has been called (nothing more runs on it)."""
        return self._closed

    def check_open(self) -> None:
        """Refuse to run on a closed connection.

        Raises:
            InputError: it is closed.
        """
        if self._closed:
            raise InputError(
                f"connection: {self.description} is closed; open another with pirate_bt.connect()"
            )

    def check_built_here(self, tree: Any) -> None:
        """Refuse a tree built in Python whose nodes were built with another connection's
        :meth:`context`: their commands would go to that connection's robot (or, closed,
        nowhere), while this one's runner ticks them. A root built once and run on one
        connection after another failed *link_down: the link to the robot is not
        connected*, or ran out its time limit, this robot never moving.

        Raises:
            InputError: naming the first such node.
        """
        import py_trees

        from pirate_bt.behaviours.base import BuildContext
        from pirate_bt.runner import node_path

        root = tree.root if isinstance(tree, py_trees.trees.BehaviourTree) else tree
        if not isinstance(root, py_trees.behaviour.Behaviour):
            return  # a file, a mapping or a LoadedTree is built for this connection
        for node in root.iterate():
            context = getattr(node, "context", None)
            if isinstance(context, BuildContext) and context.supervisor not in (
                None,
                self.supervisor,
            ):
                raise InputError(
                    f"tree: {node_path(node)!r} was built with another connection's"
                    f" context(); build it with this connection's ({self.description}):"
                    " its commands would go to the other robot"
                )

    def run(
        self,
        tree: Any,
        *,
        params: Mapping[str, Any] | None = None,
        max_time: str | float = "600 s",
        rate: str | float = "20 Hz",
        trace: str | Path | None = None,
        realtime: bool = False,
        live: bool = False,
        observe: Callable[[Any, Connection | None], None] | None = None,
    ) -> RunResult:
        """Run a tree on this connection to its end (see :func:`pirate_bt.simulate_tree`).

        A failed run is a result, not an exception; the robot is then left in its
        safe state and :attr:`RunResult.why` says why. One run at a time: a run asked
        for while another runs on this connection (from another thread) is refused.

        Raises:
            InputError: a bad option, a closed connection, or a run already going on.
        """
        self.check_built_here(tree)
        return run_on(  # holds this connection for the run (one_run)
            self,
            tree,
            params=params,
            max_time=max_time,
            rate=rate,
            trace=trace,
            realtime=realtime,
            live=live,
            observe=observe,
        )

    @contextmanager
    def one_run(self) -> Iterator[None]:
        """Hold this connection for one run: every run on it holds it (:meth:`run`,
        :func:`pirate_bt.simulate_tree`'s and :func:`pirate_bt.run_tree`'s, a runner of
        :meth:`runner`), so that one tree at a time ticks its robot.

        Raises:
            InputError: a run holds it already (on another thread, or this run's
                ``observe`` or hooks asked for another); or it is closed.
        """
        if not self._running.acquire(blocking=False):
            # two trees ticked the same robot at once: each failed on the other's
            # motor conflict, and the robot was left in its safe state
            raise InputError(
                f"connection: {self.description} is running a tree already; run one tree"
                " at a time on a connection"
            )
        try:
            self.check_open()
            yield
        finally:
            self._running.release()

    def runner(
        self,
        tree: Any,
        *,
        params: Mapping[str, Any] | None = None,
        rate: str | float = "20 Hz",
        max_time: str | float | None = None,
        setup_timeout_s: float = 15.0,
    ) -> Runner:
        """A supervised :class:`~pirate_bt.runner.Runner` for ``tree``, not yet run (for a
        loop of your own; :meth:`run` runs one to its end and explains it).

        ``max_time`` ``None`` is no limit (your loop ends the run); a limit given must
        be finite (``nan`` and ``inf`` are refused: give ``None``). ``setup_timeout_s``
        is positive (``sys.float_info.max`` skips py_trees' setup signal).

        Raises:
            ValidationFailed: the tree does not validate against this robot.
            InputError: a bad rate, time limit or setup timeout, or a closed connection.
        """
        from pirate_bt.api.options import positive_time_s, quantity, tick_period_s
        from pirate_bt.api.running import supervised_runner

        limit = (
            positive_time_s(max_time, "max_time", instead="give None for no limit")
            if max_time is not None
            else None
        )
        period_s = tick_period_s(rate, limit)
        setup = quantity(setup_timeout_s, "time", "setup_timeout_s")
        if not setup > 0:
            raise InputError(f"setup_timeout_s: {setup_timeout_s!r} must be positive")
        self.check_open()
        self.check_built_here(tree)
        runner = supervised_runner(
            self,
            as_loaded(tree, self.robot, params),
            period_s=period_s,
            max_time_s=limit,
            setup_timeout_s=setup,
        )
        # its run() holds this connection as every run does: one beside robot.run() or
        # another runner (a thread, an observe) ticked the same robot, both failing
        runner.guard = functools.partial(_held_for_runner, self)
        return runner

    def counters(self) -> Counters:
        """The counters since the connection opened (:class:`~pirate_bt.safety.tally.Counters`)."""
        return self.tally.counters()

    def close(self) -> None:
        """Close the link (and the simulator). Idempotent."""
        if self._closed:
            return
        self._closed = True
        try:
            self.supervisor.close()
            self.close_error = getattr(self.supervisor, "close_error", None)
        finally:
            if self._simulator is not None:
                self._simulator.close()

    def __enter__(self) -> Connection:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        if exc is not None and not self._closed:
            # planner code raised with the robot in an unknown state: stop it safely
            self.supervisor.safe_state(f"planner code raised {type(exc).__name__}: {exc}")
        self.close()

    def __repr__(self) -> str:
        return f"<Connection {self.description}{' (closed)' if self._closed else ''}>"

    def __reduce__(self) -> Any:
        """Refuse to go to another process or be copied: a connection is its open link
        (and its simulator), which only this process holds (``pool.submit(robot.run,
        ...)`` failed *cannot pickle '_thread.RLock' object*, naming nothing).

        Raises:
            ArgumentTypeError: always, saying what to do instead (an ``InputError`` and
                the ``TypeError`` pickle and ``copy`` expect).
        """
        from pirate_bt.errors import ArgumentTypeError

        raise ArgumentTypeError(
            f"connection: {self.description} cannot be pickled or copied: it is this"
            " process's open link to its robot; in another process (a pool's worker) open"
            " one there (pirate_bt.connect(...), or pool.submit(pirate_bt.simulate_tree,"
            " ...), whose arguments and result pickle)"
        )


@contextmanager
def _held_for_runner(connection: Connection) -> Iterator[None]:
    """What a runner of :meth:`Connection.runner` holds while it runs: its connection
    and this process's run (:func:`pirate_bt.api.process_run.only_run`)."""
    with connection.one_run(), only_run("a runner of connection.runner()"):
        yield


def connect(
    target: Any = "sim",
    *,
    robot: Any = None,
    seed: int = 0,
    faults: str | Iterable[str] | None = None,
    mode: str = "autonomous",
    firmware: bool = False,
) -> Connection:
    """Open a supervised robot: the simulator or a real PIRATEbay bridge.

    Args:
        target: ``"sim"``, ``"sim:NETWORK"``, ``"firmware:NETWORK"`` (``sim://NETWORK``
            is the same), a network file, a ``Network`` or a ``NetworkSpec``, or a
            serial port / pyserial URL (see the module docstring); a path under
            ``/dev/`` (``Path("/dev/ttyACM0")``) is that port.
        robot: The robot description: a loaded one, a file, or ``None`` for the
            bundled ``hardware/pirate.yaml``.
        seed: The simulator's seed (and the link faults'); ignored on a real robot.
        faults: Simulator and link faults, as the command line's ``--faults``.
        mode: Who is in charge at the start: ``"autonomous"`` (trees run),
            ``"supervised"`` (every PAB step waits for an operator's confirmation) or
            ``"manual"`` (the operator drives; trees are paused).
        firmware: Simulator targets only: run the pipe physics behind the real
            firmwares in simavr (the bridge and the reference PICO boards; virtual
            time) instead of the Python bridge; link faults apply, simulator faults
            do not. Needs ``make firmware``.

    Returns:
        Connection: The open connection; close it (or use ``with``).

    Raises:
        InputError: a malformed target or fault, or simulator faults on a real port
            or through the firmware.
        ValidationFailed: a robot description or network that does not validate.
        ConfigurationError: ``firmware`` and the firmwares or simavr harness are not
            built.
        LinkError: the robot cannot be reached. A port URL that is itself wrong (a
            scheme no handler has, ``bogus://x``) is a ``PortURLError``, an
            ``InputError`` too (exit 2).

    Example::

        with pirate_bt.connect("sim:lab", faults="drop=0.05") as robot:
            print(robot.description)
    """
    from pirate_bt.safety.factory import open_supervisor
    from pirate_bt.safety.operator import Mode

    kind, where = parse_target(target)
    seed = seed_value(seed)
    if flag(firmware, "firmware") and kind == "port":
        raise InputError(
            f"connect: firmware=True runs the simulator through the firmwares; {where!r} is"
            " a port (a real bridge runs its own firmware)"
        )
    if firmware:
        kind = "firmware"
    names = [m.value for m in Mode if m is not Mode.ESTOP]
    if not isinstance(mode, str) or mode not in names:
        raise InputError(f"mode: {mode!r} is not one of {', '.join(names)}"[:200])
    start_mode = Mode(mode)
    description = load_robot_like(robot)
    sim_faults, link_faults = split_faults(fault_list(faults))  # an endless one: refused
    options: dict[str, Any] = {}
    if link_faults is not None:
        options["faults"] = link_faults if "seed=" in link_faults else f"{link_faults},seed={seed}"
    if kind == "firmware":
        if sim_faults:
            raise InputError(
                "faults: simulator faults (KIND:TARGET@AT) need the Python simulator; through"
                " the firmware only link faults (KEY=VALUE) apply"
            )
        connection = _connect_firmware(description, where, start_mode, options)
    elif kind == "sim":
        check_fault_targets(sim_faults, description)
        network = _network_for(where)
        clock: Clock = SimClock()
        supervisor = open_supervisor(
            description,
            clock=clock,
            network=network,
            seed=seed,
            sim_faults=sim_faults,
            mode=start_mode,
            **options,
        )
        name = str(where) if isinstance(where, str | Path) else str(getattr(where, "name", where))
        connection = Connection(
            description,
            clock,
            supervisor,
            simulated=True,
            target=name,
            seed=seed,
            description=f"simulator: {name}",
        )
    else:
        if sim_faults:
            raise InputError(
                "faults: simulator faults (KIND:TARGET@AT) need the simulator, not a port"
            )
        clock = WallClock()
        supervisor = open_supervisor(
            description, url=where, clock=clock, mode=start_mode, **options
        )
        connection = Connection(
            description,
            clock,
            supervisor,
            simulated=False,
            target=where,
            seed=None,
            description=f"robot at {where}",
        )
    return connection


def _connect_firmware(
    description: RobotDescription, where: Any, start_mode: Any, options: dict[str, Any]
) -> Connection:
    """The pipe physics behind the bridge and PICO firmwares in simavr, supervised."""
    from pirate_bt.pipes import load_network
    from pirate_bt.safety.factory import open_supervisor
    from pirate_bt.sim.chain_open import ChainSimulator, open_firmware_chain

    network = _network_for(where)
    if isinstance(network, str):
        network = load_network(network)
    name = str(getattr(network, "name", where))
    clock = SimClock()
    simulator = ChainSimulator(open_firmware_chain(description, network, clock=clock))
    try:
        supervisor = open_supervisor(
            description, url=simulator.chain.url, clock=clock, mode=start_mode, **options
        )
    except BaseException:
        simulator.close()
        raise
    return Connection(
        description,
        clock,
        supervisor,
        simulated=True,
        target=name,
        seed=None,
        description=f"firmware chain in simavr: {name}",
        simulator=simulator,
    )


def check_fault_targets(faults: list[str], robot: Any) -> None:
    """Refuse a simulator fault whose motor, channel or board the robot lacks, as bad
    input naming the option (``faults: fault motor_stall: unknown motor ...``).

    Raises:
        FaultTargetError: the first such fault (an ``InputError``).
    """
    from pirate_bt.sim.faults import FaultTargetError, check_fault_target, parse_fault

    for text in faults:
        try:
            check_fault_target(parse_fault(text, option="faults"), robot)
        except FaultTargetError as exc:
            raise FaultTargetError(f"faults: {exc}") from None


def _network_for(where: Any) -> Any:
    """A ``Network`` as it is; a name or file resolved (a bundled name, a path).

    Raises:
        InputError: no such network, listing the bundled ones.
    """
    if isinstance(where, str | Path):
        return str(network_name(where))
    return where
