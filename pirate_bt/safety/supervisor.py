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
"""

from __future__ import annotations

import logging
import math
import threading
from collections.abc import Iterable
from dataclasses import replace
from typing import TYPE_CHECKING

from pirate_bt.clock import Clock
from pirate_bt.errors import CommandRefused, EStopLatched, LinkError
from pirate_bt.robot.commands import MotorCommand
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
    CheckContext,
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
from pirate_bt.safety.limits import limit
from pirate_bt.safety.operator import (
    Confirm,
    Confirmation,
    Deny,
    EStop,
    Mode,
    OperatorAction,
    OperatorCommand,
    OperatorInput,
    ResetEStop,
    Resume,
    SafeStop,
    SetMode,
)
from pirate_bt.safety.verdict import (
    Outcome,
    Reason,
    Source,
    Verdict,
    VerdictListener,
    VerdictLog,
    current_issuer,
    node_path,
)

if TYPE_CHECKING:
    from pirate_bt.sim import Simulator

__all__ = ["Supervisor"]

log = logging.getLogger("pirate_bt.safety")

# Refusals that say "not now, not you" rather than "this command is wrong"; they do
# not count towards the repeated-refusal limit.
_AUTHORITY = frozenset(
    {
        Reason.ESTOP_LATCHED,
        Reason.SAFE_STATE,
        Reason.TREE_PAUSED,
        Reason.NOT_CONFIRMED,
        Reason.OPERATOR_NOT_IN_CONTROL,
    }
)


class Supervisor:
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
        self.port = port
        self.robot: RobotDescription = port.robot
        self.clock = clock
        self.verdicts = VerdictLog(log_size)
        self._checks: list[Check] = list(INVARIANTS if checks is None else checks)
        self._inputs: list[OperatorInput] = list(inputs)
        self._mode = Mode.ESTOP if mode is Mode.ESTOP else mode
        self._tick = 0
        self._seq = 0
        self._safe_reason: str | None = None
        self._estop_reason: str | None = None
        self._refusals = 0
        self._targets: dict[Half, HalfTarget] = {}
        self._last_setpoint: dict[str, tuple[ControlMode, float, float]] = {}
        self._pending: list[str] = []
        self._decided: dict[str, Confirmation] = {}
        self._granted: set[str] = set()
        self._lock = threading.RLock()
        self._expander = Expander(self.robot)
        self._base_channels = self._expander.base_channels
        self._closed = False
        self.simulator: Simulator | None = None
        """The in-process simulator behind the port, when there is one."""

    # -- what the layers above read ---------------------------------------

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
    def estopped(self) -> bool:
        return self._mode is Mode.ESTOP

    def state(self) -> RobotState | None:
        """The latest snapshot from the port (read-only for behaviours)."""
        return self.port.state()

    def health(self) -> LinkHealth:
        """The link's figures."""
        return self.port.health()

    def half_states(self) -> dict[Half, ClampState]:
        """Each half's clamp state as the invariants see it now (``UNKNOWN`` without state)."""
        state = self.port.state()
        if state is None:
            return dict.fromkeys(Half, ClampState.UNKNOWN)
        return half_states(self.robot, state, self._targets)

    def stale_channels(self) -> list[tuple[str, float]]:
        """Safety-relevant channels whose readings are too old, with their ages."""
        state = self.port.state()
        if state is None:
            return [(name, math.inf) for name in self._base_channels]
        return stale_channels(self.robot, state, self._base_channels, self.clock.now())

    def link_problem(self) -> Problem | None:
        """Why the link is not fit for commands now, or ``None``."""
        health = self.port.health()
        if health.estopped:
            return Problem(Reason.ESTOP_LATCHED, "the bridge reports its e-stop latched")
        if not health.connected:
            return Problem(Reason.LINK_DOWN, "the link to the robot is not connected")
        silent = health.silent_for(self.clock.now())
        if silent > self.robot.safety.max_link_silence:
            return Problem(
                Reason.LINK_SILENT,
                f"nothing heard from the bridge for {silent:.3f} s"
                f" (allowed {self.robot.safety.max_link_silence:.3f} s)",
            )
        return None

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

    # -- the tick --------------------------------------------------------------

    def tick(self) -> None:
        """Once per runner tick, before the tree: operator actions, link, freshness.

        Operator actions due now are applied first, so a takeover or hand-back takes
        effect before the tree is next ticked. Then the link is polled; link loss,
        a silent link or stale safety readings put the robot in its safe state, and
        an e-stop reported by the bridge latches ``ESTOP``.
        """
        with self._lock:
            self._tick += 1
            now = self.clock.now()
            for source in tuple(self._inputs):
                for action in source.poll(self._tick, now):
                    self.apply(action)
            try:
                self.port.poll()
            except LinkError as exc:
                if not self.in_safe_state:
                    self.safe_state(f"link lost: {exc}")
                return
            problem = self.link_problem()
            if problem is not None and problem.reason is Reason.ESTOP_LATCHED:
                if self._mode is not Mode.ESTOP:
                    self.estop("the bridge reports its e-stop latched")
                return
            if problem is not None:
                if not self.in_safe_state:
                    self.safe_state(f"{problem.reason}: {problem.detail}")
                return
            state = self.port.state()
            if state is None:
                return
            stale = stale_channels(self.robot, state, self._base_channels, now)
            if stale and not self.in_safe_state:
                names = ", ".join(f"{n} ({a:.3f} s)" for n, a in stale[:4])
                self.safe_state(f"stale data: {names}")

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

    # -- safe state and e-stop ----------------------------------------------

    def safe_state(self, reason: str) -> None:
        """Stop the drives and hold the clamps; refuse tree commands until resumed.

        Called by the supervisor itself (stale data, link loss, repeated refusals),
        by the runner when a behaviour raises, and by an operator stop. Never raises:
        a stop that cannot be delivered is logged. The first reason given is kept
        (:attr:`safe_state_reason`) until the operator resumes: the first cause of a
        failure survives every later stop.
        """
        with self._lock:
            first = self._safe_reason is None
            if first:
                self._safe_reason = reason
                log.warning("safe state: %s", reason)
            else:
                log.debug("safe state again: %s (first cause kept: %s)", reason, self._safe_reason)
            sent = self._send_stop()
            self._record(
                Verdict(
                    Outcome.PASS,
                    Stop(),
                    Source.SUPERVISOR,
                    sent=sent,
                    reason=Reason.SAFE_STATE,
                    detail=f"safe state: {reason}",
                )
            )

    def estop(self, reason: str = "e-stop") -> None:
        """E-stop: always passes, stops everything on the bridge, latches ``ESTOP``."""
        with self._lock:
            try:
                self.port.estop()
            except Exception:  # the e-stop must never be the thing that fails
                log.exception("e-stop could not be sent")
            self._mode = Mode.ESTOP
            self._estop_reason = reason
            self._granted.clear()
            log.error("E-STOP: %s", reason)
            self._record(
                Verdict(
                    Outcome.PASS,
                    Stop(),
                    Source.SUPERVISOR,
                    reason=Reason.ESTOP_LATCHED,
                    detail=f"e-stop: {reason}",
                )
            )

    def reset_estop(self) -> None:
        """Release a latched e-stop (operator action); the supervisor comes back in ``MANUAL``."""
        with self._lock:
            if self._mode is not Mode.ESTOP:
                return
            self.port.reset_estop()
            self._mode = Mode.MANUAL
            self._estop_reason = None
            log.warning("e-stop reset by the operator; mode manual")

    # -- operator authority ---------------------------------------------------

    def set_mode(self, mode: Mode) -> None:
        """Change who is in charge; takes effect for the very next command.

        Taking over (``MANUAL``) stops the drives. Handing back (``AUTONOMOUS`` or
        ``SUPERVISED``) also leaves the safe state. ``ESTOP`` is :meth:`estop`;
        leaving ``ESTOP`` needs :meth:`reset_estop`.
        """
        with self._lock:
            if mode is Mode.ESTOP:
                self.estop("operator set mode estop")
                return
            if self._mode is Mode.ESTOP:
                log.warning("mode %s ignored: the e-stop is latched (reset it first)", mode)
                return
            if mode is self._mode:
                return
            old, self._mode = self._mode, mode
            log.warning("mode %s -> %s", old, mode)
            if mode is Mode.MANUAL:
                self._send_stop()
            else:
                self._safe_reason = None
                self._refusals = 0

    def resume(self) -> None:
        """Leave the safe state (operator action)."""
        with self._lock:
            if self._safe_reason is not None:
                log.warning("safe state left by the operator (was: %s)", self._safe_reason)
            self._safe_reason = None
            self._refusals = 0

    def apply(self, action: OperatorAction) -> Verdict | None:
        """Apply one operator action now; returns the verdict for a command action."""
        with self._lock:
            match action:
                case SetMode(mode):
                    self.set_mode(mode)
                case EStop(reason):
                    self.estop(reason)
                case ResetEStop():
                    self.reset_estop()
                case SafeStop(reason):
                    self.safe_state(reason)
                case Resume():
                    self.resume()
                case Confirm(step):
                    self.confirm(step)
                case Deny(step):
                    self.deny(step)
                case OperatorCommand(command):
                    return self.command(command, source=Source.OPERATOR)
            return None

    def request_confirmation(self, step: str) -> Confirmation:
        """Ask to start ``step`` (a primitive calls this before it moves).

        In ``AUTONOMOUS`` the answer is ``GRANTED`` at once. In ``SUPERVISED`` the
        step waits (``PENDING``) until an operator confirms or denies it; call again
        each tick. ``MANUAL`` answers ``PENDING`` (the tree is paused), ``ESTOP``
        ``DENIED``. A granted step lets the tree's commands through until
        :meth:`end_step`, which the primitive calls when it terminates.
        """
        with self._lock:
            if self._mode is Mode.ESTOP:
                return Confirmation.DENIED
            decided = self._decided.get(step)
            if decided is not None:
                return decided
            if self._mode is Mode.AUTONOMOUS:
                self._decided[step] = Confirmation.GRANTED
                self._granted.add(step)
                return Confirmation.GRANTED
            if step not in self._pending:
                self._pending.append(step)
                log.info("waiting for the operator to confirm %r", step)
            return Confirmation.PENDING

    def end_step(self, step: str) -> None:
        """Forget ``step``'s confirmation; the next request for it asks again."""
        with self._lock:
            self._decided.pop(step, None)
            self._granted.discard(step)
            if step in self._pending:
                self._pending.remove(step)

    def pending_confirmations(self) -> list[str]:
        """Steps waiting for the operator, oldest first."""
        return list(self._pending)

    def confirm(self, step: str | None = None) -> str | None:
        """Grant ``step`` (or the oldest pending one); returns the step granted."""
        return self._decide_step(step, Confirmation.GRANTED)

    def deny(self, step: str | None = None) -> str | None:
        """Deny ``step`` (or the oldest pending one); returns the step denied."""
        return self._decide_step(step, Confirmation.DENIED)

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
                self.port.close()
            finally:
                if self.simulator is not None:
                    self.simulator.close()

    # -- internals -------------------------------------------------------------

    def _decide_step(self, step: str | None, answer: Confirmation) -> str | None:
        with self._lock:
            if step is None:
                if not self._pending:
                    return None
                step = self._pending[0]
            if step in self._pending:
                self._pending.remove(step)
            self._decided[step] = answer
            if answer is Confirmation.GRANTED:
                self._granted.add(step)
            else:
                self._granted.discard(step)
            log.warning("operator %s %r", answer, step)
            return step

    def _record(self, verdict: Verdict) -> Verdict:
        self._seq += 1
        # A node whose code is running asked for this (or, for a supervisor stop, caused it).
        issuer = current_issuer() if verdict.source is not Source.OPERATOR else None
        node, node_name = node_path(issuer) if issuer is not None else (None, None)
        verdict = replace(
            verdict,
            seq=self._seq,
            tick=self._tick,
            stamp_s=self.clock.now(),
            node=node,
            node_name=node_name,
        )
        self.verdicts.append(verdict)
        if verdict.source is Source.TREE:
            if verdict.ok:
                self._refusals = 0
            elif verdict.reason not in _AUTHORITY:
                self._refusals += 1
                if self._refusals >= self.robot.safety.max_refusals and not self.in_safe_state:
                    self.safe_state(f"{self._refusals} refused commands in a row")
        return verdict

    def _send_stop(self) -> tuple[MotorCommand, ...]:
        now = self.clock.now()
        cmds = tuple(
            MotorCommand(m.name, ControlMode.VELOCITY, 0.0) for m in self.robot.drive_motors()
        )
        try:
            self.port.send(cmds)
        except LinkError as exc:
            log.error("could not send stop: %s", exc)
            return ()
        for c in cmds:
            self._last_setpoint[c.motor] = (c.mode, 0.0, now)
        return cmds

    def _refuse(self, command: Command, source: Source, reason: Reason, detail: str) -> Verdict:
        return Verdict(Outcome.REFUSE, command, source, reason=reason, detail=detail)

    def _decide(self, command: Command, source: Source, *, send: bool) -> Verdict:
        now = self.clock.now()
        if isinstance(command, Stop):
            sent = self._send_stop() if send else ()
            return Verdict(Outcome.PASS, command, source, sent=sent)
        # 1. authority
        if self._mode is Mode.ESTOP:
            return self._refuse(
                command, source, Reason.ESTOP_LATCHED, f"e-stop latched ({self._estop_reason})"
            )
        if source is Source.OPERATOR and self._mode is not Mode.MANUAL:
            return self._refuse(
                command,
                source,
                Reason.OPERATOR_NOT_IN_CONTROL,
                f"take over (mode manual) before driving by hand; mode is {self._mode}",
            )
        if source is Source.TREE:
            if self._mode is Mode.MANUAL:
                return self._refuse(
                    command, source, Reason.TREE_PAUSED, "the operator has taken over (manual)"
                )
            if self._safe_reason is not None:
                return self._refuse(
                    command, source, Reason.SAFE_STATE, f"in safe state: {self._safe_reason}"
                )
            if self._mode is Mode.SUPERVISED and not self._granted:
                return self._refuse(
                    command,
                    source,
                    Reason.NOT_CONFIRMED,
                    "supervised mode: no step has been confirmed by the operator",
                )
        # 2. link
        problem = self.link_problem()
        if problem is not None:
            return self._refuse(command, source, problem.reason, problem.detail)
        # 3. expansion
        state = self.port.state()
        expanded = self._expander.expand(command, state)
        if isinstance(expanded, Problem):
            return self._refuse(command, source, expanded.reason, expanded.detail)
        intent = expanded
        # 4. freshness
        if intent.moves or intent.channels:
            if state is None:
                return self._refuse(command, source, Reason.NO_STATE, "no state received yet")
            stale = stale_channels(self.robot, state, intent.channels, now)
            if stale:
                names = ", ".join(
                    f"{n} ({'never' if not math.isfinite(a) else f'{a:.3f} s'})" for n, a in stale
                )
                return self._refuse(
                    command, source, Reason.STALE_STATE, f"readings too old: {names}"
                )
        # 5. invariants
        if state is not None and intent.moves:
            ctx = CheckContext(
                self.robot, state, now, half_states(self.robot, state, self._targets)
            )
            for check in self._checks:
                found = check(ctx, intent)
                if found is not None:
                    return self._refuse(command, source, found.reason, found.detail)
        # 6. static limits
        out: list[MotorCommand] = []
        clips: list[tuple[Reason, str]] = []
        for mc in intent.motor_commands:
            limited = limit(self.robot, self._last_setpoint, mc, state, now)
            if isinstance(limited, Problem):
                return self._refuse(command, source, limited.reason, limited.detail)
            value, notes = limited
            clips.extend(notes)
            out.append(mc if value == mc.value else MotorCommand(mc.motor, mc.mode, value))
        sent = tuple(out)
        if send:
            try:
                self.port.send(sent)
            except LinkError as exc:
                self.safe_state(f"link error while sending: {exc}")
                return self._refuse(command, source, Reason.LINK_ERROR, str(exc))
            for mc in sent:
                self._last_setpoint[mc.motor] = (mc.mode, mc.value, now)
            # A clamp whose torque swings a joint across (a reversal) lets go on the way,
            # which the checks above treat as a release; what the half is asked to end
            # in is still the clamp, so the clamp target wins.
            for half in intent.releases - intent.clamps:
                self._targets[half] = HalfTarget.RELEASE
            for half in intent.clamps:
                self._targets[half] = HalfTarget.CLAMP
        if clips:
            return Verdict(
                Outcome.CLIP,
                command,
                source,
                sent=sent,
                reason=clips[0][0],
                detail="; ".join(d for _, d in clips),
                clips=tuple(r for r, _ in clips),
            )
        return Verdict(Outcome.PASS, command, source, sent=sent)
