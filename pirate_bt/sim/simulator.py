"""The simulator facade: a robot in a network behind a bridge, reachable by URL.

Create one per test or run::

    clock = SimClock()
    sim = Simulator("lab", robot, seed=1, clock=clock)     # or a Network object
    link = open_link(sim.url, robot, clock)                # sim.url == "sim://sim-1"
    ...
    sim.counters(), sim.truth(), sim.events()

In process, the simulator listens to the shared :class:`~pirate_bt.clock.SimClock`:
whenever host code sleeps or waits on that clock, the simulated world moves by
the same time, one state period per physics step. Nothing runs between clock
advances, so a run is a pure function of the host's actions, the network and
the seed.

The URL scheme ``sim://NAME`` is served by :mod:`pirate_bt.sim.protocol_sim`,
registered with pyserial when this package is imported; NAME is looked up in
an in-process registry that :class:`Simulator` fills and :meth:`Simulator.close`
empties.
"""

from __future__ import annotations

import itertools
import logging
import math
import threading
from collections.abc import Iterable, Mapping
from operator import attrgetter
from pathlib import Path
from types import MappingProxyType
from typing import Any
from urllib.parse import urlsplit

import serial

from pirate_bt.clock import SimClock
from pirate_bt.errors import (
    MAX_SEED,
    ArgumentTypeError,
    ArgumentValueError,
    ConfigurationError,
    PirateError,
    kind_of,
    shown,
)
from pirate_bt.pipes import FaultSpec, Network, load_network
from pirate_bt.pipes.path import PieceKind
from pirate_bt.robot.description import RobotDescription
from pirate_bt.sim.bridge import SimBridge
from pirate_bt.sim.counters import SimCounters, SimEvent
from pirate_bt.sim.faults import FaultTargetError, format_fault, parse_fault
from pirate_bt.sim.model import PipeRobotModel, SensorNoise, SimTruth
from pirate_bt.yamlfile import load_yaml

__all__ = ["SCHEME", "Simulator", "lookup", "put_in_problem"]

_log = logging.getLogger(__name__)

SCHEME = "sim"
"""URL scheme of in-process simulators: ``sim://NAME``."""

_REGISTRY: dict[str, Simulator] = {}
_REGISTRY_LOCK = threading.Lock()
_NAMES = itertools.count(1)

# The figures counters() is made of, each read in one C call: the model's physics tally
# and the bridge's link counters (the same sources as ``SimBridge.counters``).
_PHYSICS_FIGURES = attrgetter("stuck_events", "slip_events", "distance_m", "slide_m")
_BRIDGE_FIGURES = attrgetter(
    "rx_frames",
    "crc_errors",
    "frame_errors",
    "nacks",
    "frames_dropped",
    "commands_executed",
    "state_frames_sent",
    "watchdog_trips",
)

if "pirate_bt.sim" not in serial.protocol_handler_packages:
    serial.protocol_handler_packages.append("pirate_bt.sim")


def lookup(name: str) -> Simulator:
    """The registered simulator called ``name``.

    Raises:
        KeyError: no simulator of that name is open in this process.
    """
    with _REGISTRY_LOCK:
        sim = _REGISTRY.get(name)
    if sim is None:
        raise KeyError(f"no simulator named {name!r} in this process (open: {sorted(_REGISTRY)})")
    return sim


def _faults_argument(faults: object) -> list[FaultSpec]:
    """``faults`` as specs: one fault's text or spec, or an iterable of texts and specs (a
    text was iterated by its characters: ``faults: bad fault 'b'``; a spec by its fields:
    *a fault is text ... or a FaultSpec, not ('kind', 'board_reset')*)."""
    if isinstance(faults, str | FaultSpec):
        faults = [faults]
    if faults is None or isinstance(faults, bytes | Mapping) or not isinstance(faults, Iterable):
        raise ArgumentTypeError(
            f"faults: give a fault's text or a list of them (or FaultSpecs), not {kind_of(faults)}"
        )
    specs: list[FaultSpec] = []
    for fault in faults:
        if isinstance(fault, FaultSpec):
            specs.append(fault)
        elif isinstance(fault, str):
            specs.append(parse_fault(fault))
        else:
            raise ArgumentTypeError(
                f"faults: a fault is text such as 'board_reset:22@10s' or a FaultSpec,"
                f" not {shown(fault)}"
            )
    return specs


def _check_arguments(
    network: object,
    robot: object,
    seed: object,
    clock: object,
    noise: object,
    name: object,
    start_m: object,
) -> None:
    """Refuse a wrong argument in one line naming it, before anything is built (a
    string robot was ``AttributeError: 'str' object has no attribute 'clamp'``; a
    network of ``None`` was *path: give a file name ...*, naming no ``path``)."""
    if not isinstance(network, Network | str | Path):
        raise ArgumentTypeError(
            f"network: give a Network, a file name or a bundled network's name, not"
            f" {kind_of(network)}"
        )
    for option, value, kind, hint in (
        ("robot", robot, RobotDescription, "a RobotDescription (pirate_bt.robot.load_robot)"),
        ("clock", clock, SimClock, "a SimClock"),
        ("noise", noise, SensorNoise, "a SensorNoise"),
    ):
        if value is not None and not isinstance(value, kind):
            raise ArgumentTypeError(f"{option}: give {hint} or None, not {kind_of(value)}")
    if isinstance(seed, bool) or not isinstance(seed, int):
        raise ArgumentTypeError(f"seed: give a whole number, not {kind_of(seed)}")
    if not 0 <= seed <= MAX_SEED:
        raise ArgumentValueError(f"seed: {shown(seed)} is not a whole number from 0 to 2**63 - 1")
    if name is not None and not isinstance(name, str):
        raise ArgumentTypeError(f"name: give text or None, not {kind_of(name)}")
    if name is not None and (
        not name or len(name) > 200 or urlsplit(f"{SCHEME}://{name}").netloc != name
    ):
        raise ArgumentValueError(
            f"name: {shown(name)} cannot be the NAME of a {SCHEME}://NAME URL; give text of"
            " letters, digits, '-', '_' or '.' (at most 200 characters), or None"
        )
    if isinstance(start_m, int) and not isinstance(start_m, bool):
        try:
            float(start_m)
        except OverflowError:
            raise ArgumentValueError(
                f"start_m: the front tip's distance is a finite number of metres,"
                f" not {shown(start_m)}"
            ) from None


def _too_early(fault: FaultSpec, now_s: float) -> str | None:
    """Why ``fault`` cannot be scheduled when the simulated time is ``now_s``: it starts
    before (it started and ended in the same step, a board reset undone before the board
    was ever missed, while the events said it happened); ``None`` when it can."""
    if fault.at >= now_s - 1e-9:
        return None
    return (
        f"{format_fault(fault)} starts at {fault.at:g} s, but the simulated time is"
        f" {now_s:g} s already (a fault's time is the simulator's clock time): give"
        f" {now_s:g} s or later"
    )


def _as_scheduled(fault: FaultSpec, robot: RobotDescription) -> FaultSpec:
    """``fault`` as the bridge runs it: lasting at least one state period, the world's
    step (``board_reset:26@3s+1ms`` started and ended in the same step, so the board was
    never missed and the link never lost while the events said it happened), and a board
    named by its number (``022`` is board 22: ``board_reset:022@2s`` over
    ``board_reset:22@1s+3s`` was another fault, and its end brought the board back while
    the first still ran)."""
    update: dict[str, object] = {}
    target = fault.target
    if (
        fault.kind in ("board_reset", "board_fault")
        and target
        and target.isascii()
        and target.isdigit()
    ):
        update["target"] = str(int(target))
    step = robot.bridge.state_period
    duration = fault.duration
    if duration is None and fault.kind == "board_reset":
        duration = robot.bridge.reset_time
    if duration is not None and duration < step:
        update["duration"] = step
    return fault.model_copy(update=update) if update else fault


def _fault_place(network: Network, index: int, key: str = "target") -> str:
    """``file:line:column`` of ``key`` of the network file's fault ``index`` (of the
    fault when it has no such key); the network's source alone when it was not
    loaded from a file that still reads."""
    source = network.source
    try:
        if not Path(source).is_file():
            return source
        document = load_yaml(source)
    except (OSError, PirateError):
        return source
    return str(document.locator.locate(("faults", index, key)))


_ACROSS = {PieceKind.BEND: "bend", PieceKind.TEE: "T-joint", PieceKind.TEE_TURN: "T-joint"}
"""What the robot cannot be put in across (as the map side's ``task.start_check``)."""


def put_in_problem(network: Network, robot: RobotDescription) -> str | None:
    """Why ``network``'s start cannot take ``robot``, or ``None`` when it can: the robot,
    put in with its front tip at the network's start position (default: its own
    length), would lie across a bend or a T-joint (the first straight shorter than the
    robot). The map side refuses such a map at planning (``task.start_check``); such a
    *truth* was taken, and a mission on a good map failed on *belief and map disagree:
    the pipe blocked the robot at 0.59 m ...*, a reason about the map. One line naming
    the network, the piece and the length needed.
    """
    path = network.path({})
    length_m = sum(module.length for module in robot.modules)
    start = network.spec.start.position
    front_m = min(max(start if start is not None else length_m, length_m), path.length_m)
    rear_m = front_m - length_m
    under = next(
        (
            piece
            for piece in path.pieces
            if piece.kind in _ACROSS
            and piece.start_m < front_m - 1e-6
            and piece.end_m > rear_m + 1e-6
        ),
        None,
    )
    if under is None:
        return None
    where = f" ({network.source})" if network.source not in ("<network>", network.name) else ""
    return (
        f"network {network.name!r}{where}: the robot ({length_m:.2f} m long) is put in with"
        f" its front tip at {front_m:.2f} m, across the {_ACROSS[under.kind]}"
        f" {under.segment!r} ({under.start_m:.2f}-{under.end_m:.2f} m): the simulated"
        f" network needs a straight at least {length_m:.2f} m long before its first bend or"
        " T-joint (or a start position with the whole robot past it)"
    )


class Simulator:
    """PIRATE in a pipe network behind a simulated PIRATEbay, on a shared clock.

    Args:
        network: A :class:`~pirate_bt.pipes.Network`, a file path, or a bundled name.
        robot: The robot description (default: the bundled 2018 robot).
        seed: Seed for sensor noise; equal seeds and equal host actions give equal runs.
        clock: The simulated clock shared with the host (default: a new one).
        noise: Sensor noise (default: none).
        faults: Faults to inject, as :class:`FaultSpec` or text
            (``"board_reset:22@10s"``), on top of those in the network file.
        name: Registry name, the NAME of ``sim://NAME`` (default: ``sim-N``).
        start_m: Front-tip distance along the main line at the start.

    Raises:
        ConfigurationError: a fault names something the robot lacks, or the name is taken;
            the network's start puts the robot in across a bend or a T-joint (its
            first straight shorter than the robot; not checked for a given ``start_m``).
        ValidationFailed: the network file does not validate.
    """

    def __init__(
        self,
        network: Network | str | Path,
        robot: RobotDescription | None = None,
        *,
        seed: int = 0,
        clock: SimClock | None = None,
        noise: SensorNoise | None = None,
        faults: Iterable[FaultSpec | str] = (),
        name: str | None = None,
        start_m: float | None = None,
    ) -> None:
        _check_arguments(network, robot, seed, clock, noise, name, start_m)
        specs = _faults_argument(faults)
        if robot is None:
            from pirate_bt.robot import load_robot

            robot = load_robot()
        if not isinstance(network, Network):
            network = load_network(network)
        self.robot = robot
        self.network = network
        self.clock = clock if clock is not None else SimClock()
        self.seed = seed
        self.model = PipeRobotModel(robot, network, seed=seed, noise=noise, start_m=start_m)
        problem = put_in_problem(network, robot) if start_m is None else None
        if problem is not None:  # a start_m given is the caller's to choose
            raise ConfigurationError(problem)
        self.bridge = SimBridge(self.model, start_s=self.clock.now())
        self.model.time_s = self.clock.now()
        self._lock = threading.RLock()
        self._counters = SimCounters()
        self._counter_figures: tuple[Any, ...] | None = None
        self._violations: Mapping[str, int] = MappingProxyType({})
        self._damage: Mapping[str, int] = MappingProxyType({})
        for index, fault in enumerate(network.faults):
            try:
                self.bridge.check_fault(fault)
            except FaultTargetError as exc:  # said where the network file writes it
                raise FaultTargetError(f"{_fault_place(network, index)}: faults: {exc}") from None
            early = _too_early(fault, self.bridge.now_s)
            if early is not None:
                raise ConfigurationError(f"{_fault_place(network, index, 'at')}: faults: {early}")
        self.bridge.schedule([_as_scheduled(f, robot) for f in network.faults])
        self.schedule(specs)
        self.name = name or f"sim-{next(_NAMES)}"
        with _REGISTRY_LOCK:
            if self.name in _REGISTRY:
                raise ConfigurationError(f"a simulator named {self.name!r} is already open")
            _REGISTRY[self.name] = self
        self.clock.add_listener(self._on_clock)
        self._closed = False
        _log.info("simulator %s: %s in %s, seed %d", self.name, robot.name, network.name, seed)

    @property
    def url(self) -> str:
        """The pyserial URL that reaches this simulator's bridge in this process."""
        return f"{SCHEME}://{self.name}"

    def schedule(self, faults: Iterable[FaultSpec | str]) -> None:
        """Inject faults at their simulated times (``FaultSpec`` or ``KIND[:TARGET]@AT[+DUR]``).

        A fault's time is the simulator's clock time: one before the simulated time now
        is refused (it would start and end in one step, doing nothing). A fault lasts at
        least one state period (``bridge.state_period``, the world's step): a shorter
        duration is taken as one period.

        Raises:
            InputError: malformed fault text, or ``faults`` no text nor list of faults;
                a fault that starts before the simulated time now (an
                ``ArgumentValueError``). All or none: a refused list schedules nothing.
            ConfigurationError: unknown motor, channel or board.
        """
        specs = _faults_argument(faults)
        with self._lock:
            now_s = self.bridge.now_s  # the world's time (advance_to moves it, not the clock)
            for fault in specs:
                early = _too_early(fault, now_s)
                if early is not None:
                    raise ArgumentValueError(f"faults: {early}")
            self.bridge.schedule([_as_scheduled(f, self.robot) for f in specs])

    def _on_clock(self, now_s: float) -> None:
        with self._lock:
            self.bridge.advance_to(now_s)

    def advance_to(self, now_s: float) -> None:
        """Run the world up to ``now_s`` (the clock listener does this in process).

        Raises:
            ArgumentTypeError: ``now_s`` is no number; ArgumentValueError: it is not
                finite (``inf`` stepped the world for ever, ``nan`` did nothing).
        """
        if isinstance(now_s, bool) or not isinstance(now_s, int | float):
            raise ArgumentTypeError(f"now_s: give a time in seconds, not {kind_of(now_s)}")
        try:
            finite = math.isfinite(now_s)
        except OverflowError:
            finite = False
        if not finite:
            raise ArgumentValueError(f"now_s: {shown(now_s)} is not a finite time in seconds")
        self._on_clock(now_s)

    # -- bytes (used by the sim:// port and the pty/TCP server) ----------------------

    def write(self, data: bytes) -> None:
        """Bytes from the host to the bridge."""
        if not isinstance(data, bytes | bytearray | memoryview):
            raise ArgumentTypeError(f"data: give bytes, not {kind_of(data)}")
        with self._lock:
            self.bridge.receive(data)

    def read(self, size: int = -1) -> bytes:
        """Bytes from the bridge to the host (up to ``size``; all when negative)."""
        if isinstance(size, bool) or not isinstance(size, int):
            raise ArgumentTypeError(f"size: give a whole number of bytes, not {kind_of(size)}")
        with self._lock:
            return self.bridge.read(size)

    @property
    def in_waiting(self) -> int:
        return self.bridge.pending_bytes

    # -- oracles --------------------------------------------------------------------

    def counters(self) -> SimCounters:
        """Violations, damage, stuck events, distance, and frame counters so far.

        Read every tick by traces, so it is cheap: the figures are read as two tuples
        and compared with the last snapshot's; while none changed, the same immutable
        snapshot is returned (compare with ``is`` to skip work). Otherwise one new
        snapshot is built, reusing the violation and damage mappings when those did
        not change. Equal to ``bridge.counters()`` at every moment.
        """
        with self._lock:
            # The tally is the model's own mutable record (``model.counters()`` copies
            # it); reading it here saves building a second snapshot every tick.
            tally = self.model._tally
            bridge = self.bridge
            figures = (_PHYSICS_FIGURES(tally), _BRIDGE_FIGURES(bridge))
            violations, damage = tally.violations, tally.damage
            same_maps = violations == self._violations and damage == self._damage
            if figures == self._counter_figures and same_maps:
                return self._counters
            if not same_maps:
                self._violations = MappingProxyType(dict(violations))
                self._damage = MappingProxyType(dict(damage))
            (
                (stuck, slips, distance_m, slide_m),
                (rx, crc, framing, nacks, dropped, run, sent, trips),
            ) = figures
            self._counter_figures = figures
            self._counters = SimCounters(
                violations=self._violations,
                damage=self._damage,
                stuck_events=stuck,
                slip_events=slips,
                distance_m=distance_m,
                slide_m=slide_m,
                frames_received=rx,
                frames_rejected=crc + framing + nacks,
                frames_dropped=dropped,
                commands_executed=run,
                state_frames_sent=sent,
                watchdog_trips=trips,
            )
            return self._counters

    def truth(self) -> SimTruth:
        """Ground truth now: positions, segments, rolls, clamps, joint angles."""
        with self._lock:
            return self.model.truth()

    def events(self) -> list[SimEvent]:
        """Every event so far, in time order."""
        with self._lock:
            return list(self.model.events)

    @property
    def closed(self) -> bool:
        """Whether :meth:`close` was called: a ``sim://`` port to it then fails as a
        device unplugged does."""
        return self._closed

    def close(self) -> None:
        """Stop listening to the clock and free the name (idempotent)."""
        if self._closed:
            return
        self._closed = True
        self.clock.remove_listener(self._on_clock)
        with _REGISTRY_LOCK:
            if _REGISTRY.get(self.name) is self:
                del _REGISTRY[self.name]

    def __enter__(self) -> Simulator:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"Simulator({self.name!r}, {self.network.name!r}, seed={self.seed})"
