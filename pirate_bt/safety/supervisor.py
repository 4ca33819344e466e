"""The Supervisor: the one object that sends commands to the robot.

Every command - from a tree, from planner code, from an operator - goes through
:meth:`Supervisor.command`, which checks it in this order and stops at the first
refusal:

1. **authority** - the mode (e-stop latched, tree paused in manual, step not
   confirmed in supervised, operator not in control) and the safe state;
2. **link** - connected, not e-stopped on the bridge, heard from recently;
3. **expansion** - the command names a real role or motor in a mode it allows;
4. **freshness** - every sensor reading the decision relies on is recent;
5. **state invariants** - :data:`~pirate_bt.safety.checks.INVARIANTS`;
6. **static limits** - angle range, torque, speed, and rate of change from the
   robot description, each clipped or refused by that limit's policy.

The answer is a :class:`~pirate_bt.safety.verdict.Verdict`: pass, clip (with the
commands as sent) or refuse (with a :class:`~pirate_bt.safety.verdict.Reason`).
:meth:`Supervisor.command` returns refusals; :meth:`Supervisor.require` raises
them as :class:`~pirate_bt.errors.CommandRefused`. Either way a refusal never
looks like success. ``Stop`` always passes.

The runner calls :meth:`Supervisor.tick` once per tick before ticking the tree:
it applies due operator actions, polls the link, and enters the safe state on
link loss or stale data. :meth:`Supervisor.safe_state` stops the drives and
holds the clamps (joint setpoints are left as they are, so the boards keep
holding); :meth:`Supervisor.estop` always passes, stops everything on the bridge
and latches until an operator resets it.

The class is split along its seams, one mixin per module:

- :mod:`pirate_bt.safety.supervisor_decide` (:class:`DecisionMixin`): the
  checks above in order, sending, recording verdicts, counting refusals, the
  drive stop.
- :mod:`pirate_bt.safety.supervisor_authority` (:class:`AuthorityMixin`): the
  safe state, the e-stop, modes, operator actions and step confirmations.
- :mod:`pirate_bt.safety.supervisor_hold` (:class:`HoldMixin`): the protective
  hold, which clamps on its own when nothing holds the robot in a steep pipe.
- :mod:`pirate_bt.safety.supervisor_stall` (:class:`StallMixin`): lets a joint go
  that stays still short of its position setpoint (a stalled motor).
- :mod:`pirate_bt.safety.supervisor_stale` (:func:`stale_cause`): why the safety
  readings went stale, for the safe state's cause (the link silent, or a board away).

This module keeps :class:`Supervisor` itself: its construction, what the layers
above read, the tick, the command entry points, the simulator and closing.
"""

from __future__ import annotations

import logging
import math
import threading
from collections.abc import Iterable
from typing import TYPE_CHECKING, Any

from pirate_bt.clock import Clock
from pirate_bt.errors import (
    CommandRefused,
    EStopLatched,
    InputError,
    LinkError,
    ProtocolMismatch,
)
from pirate_bt.link.closing import EStopNotTaken, RequestsFailed
from pirate_bt.robot.description import (
    ControlMode,
    Half,
    RobotDescription,
)
from pirate_bt.robot.port import LinkHealth, RobotPort
from pirate_bt.robot.state import RobotState
from pirate_bt.safety.checks import (
    INVARIANTS,
    Check,
    ClampState,
    HalfTarget,
    Problem,
    half_states,
    stale_channels,
)
from pirate_bt.safety.commands import (
    Bend,
    Clamp,
    Command,
    Drive,
    MoveFrontClear,
    Rotate,
    Stop,
    Tilt,
    Unclamp,
)
from pirate_bt.safety.expand import Expander
from pirate_bt.safety.limits import drive_reach
from pirate_bt.safety.operator import (
    Confirmation,
    Mode,
    OperatorInput,
)
from pirate_bt.safety.port_view import PortView
from pirate_bt.safety.supervisor_authority import AuthorityMixin, as_mode
from pirate_bt.safety.supervisor_decide import DecisionMixin, board_readings
from pirate_bt.safety.supervisor_hold import HoldMixin, half_channels, hold_torque
from pirate_bt.safety.supervisor_stale import stale_cause
from pirate_bt.safety.supervisor_stall import StallMixin
from pirate_bt.safety.verdict import (
    Reason,
    Source,
    Verdict,
    VerdictListener,
    VerdictLog,
)

if TYPE_CHECKING:
    from pirate_bt.sim import Simulator

__all__ = ["PortView", "Supervisor"]

log = logging.getLogger("pirate_bt.safety")


class Supervisor(AuthorityMixin, DecisionMixin, HoldMixin, StallMixin):
    """Checks every command against limits, invariants and authority; the only sender.

    Args:
        port: The connected robot (real or simulated). Only the supervisor calls its
            ``send``/``estop``.
        clock: The clock every freshness and rate check reads.
        mode: The mode to start in.
        inputs: Operator input sources drained at the start of every :meth:`tick`.
        checks: The state invariants (default :data:`~pirate_bt.safety.checks.INVARIANTS`).
        log_size: How many verdicts :attr:`verdicts` keeps.
    """

    def __init__(
        self,
        port: RobotPort,
        clock: Clock,
        *,
        mode: Mode = Mode.AUTONOMOUS,
        inputs: Iterable[OperatorInput] = (),
        checks: Iterable[Check] | None = None,
        log_size: int = 1000,
    ) -> None:
        self._port = port
        self._view = PortView(port)
        self.robot: RobotDescription = port.robot
        self.clock = clock
        self.verdicts = VerdictLog(log_size)
        self._checks: list[Check] = list(INVARIANTS if checks is None else checks)
        self._inputs: list[OperatorInput] = list(inputs)
        self._mode = as_mode(mode)  # its text too ("manual"); checks compare by identity
        self._tick = 0
        self._seq = 0
        self._safe_reason: str | None = None
        self._safe_error: BaseException | None = None
        self._estop_reason: str | None = None
        self._refusals = 0
        self._node_refusals: dict[str, int] = {}  # node path id -> refusals since it passed
        self._targets: dict[Half, HalfTarget] = {}
        self._last_setpoint: dict[str, tuple[ControlMode, float, float]] = {}
        self._owners: dict[str, Any] = {}  # motor -> the tree node that last commanded it
        self._stop_unsent_said = False  # a stop the link refused was said (once a loss)
        self._pending: list[str] = []
        self._decided: dict[str, Confirmation] = {}
        self._granted: set[str] = set()
        self._lock = threading.RLock()
        self._expander = Expander(self.robot)
        self._board_readings = board_readings(self.robot)
        self._base_channels = self._expander.base_channels
        self._holding: set[Half] = set()  # halves clamped by the protective hold
        self._hold_refused: set[Half] = set()  # a protective clamp refused (logged once)
        self._hold_clearing = False  # the hold tilts the front module clear to clamp it
        self._ever_held = False  # a half has held the robot since the start
        self._run_ended = False  # a run ended: no tree's first clamp is on its way now
        self._hold_sent_s = -math.inf  # when the latest protective clamp was sent
        self._was_steep = False  # the pitch was over the unclamped limit on the last tick
        self._hold_torque = hold_torque(self.robot)
        self._half_channels = half_channels(self.robot)
        self._closed = False
        self.close_error: LinkError | None = None
        """Set by :meth:`close` when the port could not make sure the robot stopped."""
        self.simulator: Simulator | None = None
        """The in-process simulator behind the port, when there is one."""
        if self._mode is Mode.ESTOP:
            # started latched: an e-stop as SetMode("estop") is, sent to the bridge with
            # its reason (it was a mode alone: the bridge not latched, 'e-stop latched
            # (None)' on every refusal)
            self.estop("the supervisor was started in mode estop")

    # -- what the layers above read ---------------------------------------

    @property
    def port(self) -> PortView:
        """The robot port, read-only: its readings, health and polling, never a command.

        Everything that moves the robot goes through :meth:`command` (and
        :meth:`estop`); before 2026-11-29 this was the port itself, and
        ``connection.supervisor.port.send(...)`` reached the link past every check."""
        return self._view

    @property
    def mode(self) -> Mode:
        """Who is in charge now."""
        return self._mode

    @property
    def tick_count(self) -> int:
        """How many times :meth:`tick` has run."""
        return self._tick

    @property
    def tree_paused(self) -> bool:
        """True when the runner must not tick the tree (``MANUAL`` or ``ESTOP``)."""
        return self._mode in (Mode.MANUAL, Mode.ESTOP)

    @property
    def in_safe_state(self) -> bool:
        """True from :meth:`safe_state` until :class:`~pirate_bt.safety.operator.Resume`."""
        return self._safe_reason is not None

    @property
    def safe_state_reason(self) -> str | None:
        """Why the robot is in its safe state: the *first* cause given since it entered
        it (a later :meth:`safe_state` call, such as the runner's at the end of a failed
        run, stops the robot again but does not overwrite the cause); ``None`` when not
        in the safe state."""
        return self._safe_reason

    @property
    def safe_state_error(self) -> BaseException | None:
        """The exception behind :attr:`safe_state_reason`, when the first cause was one:
        the :class:`~pirate_bt.errors.LinkError` of a link lost or silent (a run that
        ends on it exits with code 3, a link error); ``None`` otherwise."""
        return self._safe_error

    @property
    def run_halted(self) -> str | None:
        """Why a tree run on this supervisor cannot go on, or ``None``: the robot is
        e-stopped, or held in its safe state (link lost or silent, stale readings, a
        fall held, a failed step), and no operator input is attached to reset or resume
        it. Primitives fail at once then, but a tree of waits and conditions would run
        on to success with nothing heard from the robot; the runners end the run at
        the next tick instead, as a failure naming this."""
        if self.operator_attached:
            return None
        if self._mode is Mode.ESTOP:
            return f"e-stop latched: {self._estop_reason}"
        if self._safe_reason is not None:
            return f"the robot is in its safe state: {self._safe_reason}"
        return None

    @property
    def estopped(self) -> bool:
        return self._mode is Mode.ESTOP

    @property
    def estop_reason(self) -> str | None:
        """Why the e-stop latched (``None`` when it is not latched)."""
        return self._estop_reason if self._mode is Mode.ESTOP else None

    def state(self) -> RobotState | None:
        """The latest snapshot from the port (read-only for behaviours)."""
        return self._port.state()

    def health(self) -> LinkHealth:
        """The link's figures."""
        return self._port.health()

    def half_states(self) -> dict[Half, ClampState]:
        """Each half's clamp state as the invariants see it now (``UNKNOWN`` without state)."""
        state = self._port.state()
        if state is None:
            return dict.fromkeys(Half, ClampState.UNKNOWN)
        return half_states(self.robot, state, self._targets)

    def stale_channels(self) -> list[tuple[str, float]]:
        """Safety-relevant channels whose readings are too old, with their ages."""
        state = self._port.state()
        if state is None:
            return [(name, math.inf) for name in self._base_channels]
        return stale_channels(self.robot, state, self._base_channels, self.clock.now())

    def link_problem(self) -> Problem | None:
        """Why the link is not fit for commands now, or ``None``."""
        health = self._port.health()
        if health.estopped:
            if health.estop_input:
                return Problem(
                    Reason.ESTOP_LATCHED,
                    "the bridge reports its e-stop latched by its hardware e-stop input"
                    " (release the button, then reset the e-stop)",
                )
            if health.bridge_resets:
                # a bridge boots latched, and the host does not release a latch from a
                # reset in the middle of a session (docs/protocol.md): say so
                return Problem(
                    Reason.ESTOP_LATCHED,
                    "the bridge reports its e-stop latched: it reset in the middle of the"
                    " session and booted latched (check the robot, then reset the e-stop)",
                )
            if health.latch_kept:  # the latch the link found when it opened, kept: why
                faulted = health.faulted_boards
                boards = (
                    f"; board {', '.join(map(str, faulted))} reports FAULT (a bridge keeps"
                    " its latch while a board is in FAULT or TIMEOUT)"
                    if faulted
                    else ""
                )
                return Problem(
                    Reason.ESTOP_LATCHED,
                    f"the bridge reports its e-stop latched: {health.latch_kept}{boards}",
                )
            return Problem(Reason.ESTOP_LATCHED, "the bridge reports its e-stop latched")
        if not health.connected:
            return Problem(Reason.LINK_DOWN, "the link to the robot is not connected")
        silent = health.silent_for(self.clock.now())
        if silent > self.robot.safety.max_link_silence:
            return Problem(
                Reason.LINK_SILENT,
                f"{health.silence_text(silent)}"
                f" (allowed {self.robot.safety.max_link_silence:.3f} s)",
            )
        if health.faulted_boards:
            return Problem(Reason.BOARD_FAULT, self._board_fault_detail(health.faulted_boards))
        if health.bus_fault:
            return Problem(
                Reason.BUS_FAULT,
                "the bridge reports BUS_FAULT: no board answered its last whole RS485"
                " poll cycle (the boards' power or the bus)",
            )
        return None

    def _board_fault_detail(self, boards: tuple[int, ...]) -> str:
        """Name the boards in ``FAULT`` and what they carry."""
        parts = []
        for board in boards:
            motors = [m.name for m in self.robot.board(board).motors]
            parts.append(f"{board} ({', '.join(motors)})" if motors else str(board))
        which = "board" if len(boards) == 1 else "boards"
        verb = "reports" if len(boards) == 1 else "report"
        return (
            f"{which} {'; '.join(parts)} {verb} FAULT (an H-bridge fault or over-current):"
            " its motors cannot be driven"
        )

    def add_listener(self, listener: VerdictListener) -> None:
        """Call ``listener(verdict)`` for every verdict from now on (the trace uses this)."""
        self.verdicts.add_listener(listener)

    def verdicts_since(self, tick: int) -> list[Verdict]:
        """Every kept verdict from supervisor tick ``tick`` on."""
        return self.verdicts.since(tick=tick)

    def add_check(self, check: Check) -> None:
        """Add a state invariant, checked after the built-in ones."""
        self._checks.append(check)

    def add_input(self, source: OperatorInput) -> None:
        """Drain ``source`` for operator actions at the start of every tick."""
        self._inputs.append(source)

    @property
    def operator_attached(self) -> bool:
        """True when an operator input (a console, a scripted operator) is drained each
        tick: someone who could release a latched e-stop or hand control back. An input
        whose ``releases`` is false (it only stops: the ROS 2 e-stop topic) does not
        count."""
        return any(getattr(source, "releases", True) for source in self._inputs)

    # -- the tick --------------------------------------------------------------

    def tick(self) -> None:
        """Once per runner tick, before the tree: operator actions, link, freshness.

        Operator actions due now are applied first, so a takeover or hand-back takes
        effect before the tree is next ticked. Then the link is polled; link loss,
        a silent link or stale safety readings put the robot in its safe state, and
        an e-stop reported by the bridge latches ``ESTOP``. Last, the protective hold:
        in a steep pipe with no half holding, the halves that do not hold are clamped.
        """
        with self._lock:
            self._tick += 1
            now = self.clock.now()
            for source in tuple(self._inputs):
                for action in source.poll(self._tick, now):
                    try:
                        self.apply(action)
                    except InputError as exc:  # the run goes on; the operator is told
                        log.error("operator input %s: %s", type(source).__name__, exc)
            failed: RequestsFailed | None = None
            try:
                self._port.poll()
            except RequestsFailed as exc:
                failed = exc  # said after the link's own problems (a bridge reset fails them)
            except LinkError as exc:
                if not self.in_safe_state:
                    # a bridge of another layout or protocol still hears the host: the
                    # link is not lost (and the safe state's stop falls back to its e-stop)
                    lost = (
                        "protocol mismatch"
                        if isinstance(exc, ProtocolMismatch)
                        else "e-stop not latched"  # the drives stop by setpoint instead
                        if isinstance(exc, EStopNotTaken)
                        else "link lost"
                    )
                    self.safe_state(f"{lost}: {exc}", error=exc)
                return
            self._resend_owed_stop()
            problem = self.link_problem()
            if problem is not None and problem.reason is Reason.ESTOP_LATCHED:
                if self._mode is not Mode.ESTOP:
                    self.estop(problem.detail)
                    health = self._port.health()
                    if health.bridge_resets and not health.estop_input and not self.in_safe_state:
                        # a bridge that reset in the session (a brown-out, its watchdog)
                        # is a hardware error: a run that ends on it exits 3, as on a
                        # lost link; a pressed e-stop input is someone's stop (exit 1)
                        cause = f"e-stop: {problem.detail}"
                        self.safe_state(cause, error=LinkError(cause))
                return
            if problem is not None:
                if not self.in_safe_state:
                    cause = f"{problem.reason}: {problem.detail}"
                    self.safe_state(cause, error=LinkError(cause))
                if problem.reason not in (Reason.BOARD_FAULT, Reason.BUS_FAULT):
                    return
                # the link works: the protective hold below may still reach the boards
                # that are not in fault (a clamp board in FAULT lets its half go limp)
            if failed is not None and not self.in_safe_state:
                # a request given up while the tree sent nothing (a long wait): until
                # 2026-12-01 said only at the tree's next send, or never
                self.safe_state(f"link error while sending: {failed}", error=failed)
            state = self._port.state()
            if state is None:
                return
            stale = stale_channels(self.robot, state, self._base_channels, now)
            if stale and not self.in_safe_state:
                cause, error = stale_cause(self.robot, self._port, state, stale, now)
                self.safe_state(cause, error=error)
            self._hold_each_state(state, now)
            self._watch_stalls(state, now)

    # -- commands ------------------------------------------------------------

    def command(self, command: Command, *, source: Source = Source.TREE) -> Verdict:
        """Check ``command``; send it (or its clipped form) unless refused.

        Args:
            command: Any :data:`~pirate_bt.safety.commands.Command`.
            source: Who asks (``TREE`` for behaviours and planner code).

        Returns:
            The verdict, also logged and appended to :attr:`verdicts`. A refused
            command returns a verdict with ``ok == False``; the caller must fail.
        """
        with self._lock:
            verdict = self._decide(command, source, send=True)
            return self._record(verdict)

    def check(self, command: Command, *, source: Source = Source.TREE) -> Verdict:
        """What :meth:`command` would decide, without sending or recording anything."""
        with self._lock:
            return self._decide(command, source, send=False)

    def drive_reach(self, velocity_mps: float) -> float:
        """The drive speed nearest ``velocity_mps`` a ``Drive`` may ask for now without
        a drive motor's acceleration limit refusing or clipping it (``velocity_mps``
        itself where none does): a drive steps toward its speed by this, tick by tick.

        Raises:
            InputError: ``velocity_mps`` is no finite number (``"80 mm/s"`` raised
                ``TypeError`` from inside the reckoning, NaN came back as NaN).
        """
        if not _finite(velocity_mps):
            try:
                shown = repr(velocity_mps)[:80]
            except ValueError:  # an integer of more digits than Python turns into text
                shown = "a number too long to show"
            raise InputError(f"drive_reach: {shown} is no speed (a finite number of m/s)")
        with self._lock:
            return drive_reach(
                self.robot, self._last_setpoint, velocity_mps, self._port.state(), self.clock.now()
            )

    def require(self, command: Command, *, source: Source = Source.TREE) -> Verdict:
        """Like :meth:`command`, but a refusal raises.

        Raises:
            EStopLatched: the e-stop is latched.
            CommandRefused: any other refusal; ``reason`` is the
                :class:`~pirate_bt.safety.verdict.Reason` value.
        """
        verdict = self.command(command, source=source)
        if verdict.refused:
            assert verdict.reason is not None
            if verdict.reason is Reason.ESTOP_LATCHED:
                raise EStopLatched(verdict.detail)
            raise CommandRefused(verdict.reason.value, verdict.detail, command)
        return verdict

    # Convenience forms the motion primitives call.

    def clamp(self, half: Half, torque_nm: float, *, source: Source = Source.TREE) -> Verdict:
        return self.command(Clamp(half, torque_nm), source=source)

    def unclamp(self, half: Half, *, source: Source = Source.TREE) -> Verdict:
        return self.command(Unclamp(half), source=source)

    def drive(self, velocity_mps: float, *, source: Source = Source.TREE) -> Verdict:
        return self.command(Drive(velocity_mps), source=source)

    def bend(self, module: str, angle_rad: float, *, source: Source = Source.TREE) -> Verdict:
        return self.command(Bend(module, angle_rad), source=source)

    def rotate(self, angle_rad: float, *, source: Source = Source.TREE) -> Verdict:
        return self.command(Rotate(angle_rad), source=source)

    def tilt(self, angle_rad: float, *, source: Source = Source.TREE) -> Verdict:
        return self.command(Tilt(angle_rad), source=source)

    def move_front_clear(self, sign: int = 1, *, source: Source = Source.TREE) -> Verdict:
        return self.command(MoveFrontClear(sign), source=source)

    def stop(self, *, source: Source = Source.TREE) -> Verdict:
        return self.command(Stop(), source=source)

    def attach_simulator(self, simulator: Simulator) -> None:
        """Keep the in-process simulator behind the port; :meth:`close` closes it too.

        :func:`~pirate_bt.safety.factory.open_supervisor` calls this; tests and
        planner code read the simulator's oracles through :attr:`simulator`.
        """
        self.simulator = simulator

    def close(self) -> None:
        """Stop the drives, close the port and, if attached, the simulator (idempotent)."""
        with self._lock:
            if self._closed:
                return
            self._closed = True
            try:
                self._send_stop()
                self._port.close()
                # the port's close never raises; a link says here what it could not stop
                self.close_error = getattr(self._port, "close_error", None)
            finally:
                if self.simulator is not None:
                    self.simulator.close()


def _finite(value: object) -> bool:
    """A real, finite number (not a bool, not text, not one too large for a float)."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        return False
    try:
        return math.isfinite(value)
    except OverflowError:
        return False
