"""Who may command the robot now: modes, the safe state, the e-stop, confirmations.

:class:`AuthorityMixin` is the authority side of
:class:`~pirate_bt.safety.supervisor.Supervisor`: entering and leaving the safe
state (:meth:`~AuthorityMixin.safe_state`, :meth:`~AuthorityMixin.resume`), the
latched e-stop (:meth:`~AuthorityMixin.estop`, :meth:`~AuthorityMixin.reset_estop`),
the mode (:meth:`~AuthorityMixin.set_mode`), operator actions
(:meth:`~AuthorityMixin.apply`) and the step confirmations of ``SUPERVISED``
mode (:meth:`~AuthorityMixin.request_confirmation` and the rest). What these
decide is what the first check of every command (authority) reads.
"""

from __future__ import annotations

import logging
import threading
from typing import TYPE_CHECKING

from pirate_bt.errors import InputError, LinkError, cut_reason
from pirate_bt.robot.commands import MotorCommand
from pirate_bt.robot.description import ControlMode, MotorFunction
from pirate_bt.safety.checks import stale_channels
from pirate_bt.safety.commands import Command, Stop, member_of
from pirate_bt.safety.operator import (
    Confirm,
    Confirmation,
    Deny,
    EStop,
    Mode,
    OperatorAction,
    OperatorCommand,
    ResetEStop,
    Resume,
    SafeStop,
    SetMode,
)
from pirate_bt.safety.supervisor_decide import DecisionMixin
from pirate_bt.safety.verdict import Outcome, Reason, Source, Verdict

__all__ = ["AuthorityMixin"]

log = logging.getLogger("pirate_bt.safety")


class AuthorityMixin(DecisionMixin):
    """The authority side of the supervisor (mixed into ``Supervisor``)."""

    # set by the supervisor
    _pending: list[str]
    _decided: dict[str, Confirmation]
    _lock: threading.RLock
    # steps granted when an e-stop came, waiting again: their nodes still run
    _interrupted: frozenset[str] = frozenset()
    estop_reset_refusal: str | None = None
    """Why the bridge refused the last e-stop reset (``None``: it did not)."""
    safe_state_entries: int = 0
    """How many times the robot has entered its safe state (a stop repeated in it
    counts once; a resume and a new cause count again)."""

    if TYPE_CHECKING:  # defined by the supervisor

        def command(self, command: Command, *, source: Source = Source.TREE) -> Verdict: ...

    # -- safe state and e-stop ----------------------------------------------

    def safe_state(self, reason: str, *, error: BaseException | None = None) -> None:
        """Stop the drives and hold the clamps; refuse tree commands until resumed.

        Called by the supervisor itself (stale data, link loss, repeated refusals),
        by the runner when a behaviour raises, and by an operator stop. Never raises:
        a stop that cannot be delivered is logged. The first reason given is kept
        (:attr:`safe_state_reason`) until the operator resumes: the first cause of a
        failure survives every later stop.

        ``error`` is the exception behind that cause, when there is one (the
        :class:`~pirate_bt.errors.LinkError` of a lost link): kept with it as
        :attr:`safe_state_error`, so a run that ends on it exits as a link error.
        """
        reason = _reason_text(reason, "safe state")
        with self._lock:
            first = self._safe_reason is None
            if first:
                self._safe_reason = reason
                self._safe_error = error
                self.safe_state_entries += 1
                log.warning("safe state: %s", reason)
            else:
                log.debug("safe state again: %s (first cause kept: %s)", reason, self._safe_reason)
            braked = self._brake_rotation()  # before the stop, whose send is the last
            sent = self._send_stop() + braked
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

    def _brake_rotation(self) -> tuple[MotorCommand, ...]:
        """Brake the rotation where it is (PWM 0), as every stop does (docs/safety.md,
        *Stop category*): a rotation on its way to its last setpoint would otherwise
        finish that step after the safe state (6° on the bundled robot at 10 Hz)."""
        if self._mode is Mode.ESTOP:
            return ()  # the bridge has braked it, and takes no setpoint
        cmds = tuple(
            MotorCommand(m.name, ControlMode.PWM, 0.0)
            for _, m in self.robot.motors()
            if m.function is MotorFunction.ROTATE and m.modes.get(ControlMode.PWM) is not None
        )
        if not cmds:
            return ()
        try:
            self._port.send(cmds)
        except LinkError as exc:
            log.info("could not brake the rotation: %s", exc)
            return ()
        now = self.clock.now()
        for c in cmds:
            self._last_setpoint[c.motor] = (c.mode, c.value, now)
        return cmds

    def estop(self, reason: str = "e-stop") -> None:
        """E-stop: always passes, stops everything on the bridge, latches ``ESTOP``."""
        reason = _reason_text(reason, "e-stop")
        with self._lock:
            try:
                self._port.estop()
            except Exception:  # the e-stop must never be the thing that fails
                log.exception("e-stop could not be sent")
            self._mode = Mode.ESTOP
            self._estop_reason = reason
            self._stopped_by_estop()
            # the steps confirmed before wait again, for the operator to confirm after
            # the reset: a step's node asks only once, so a grant forgotten alone (its
            # answer kept) left its commands refused, with nothing waiting to confirm
            for step in self._granted:
                self._decided.pop(step, None)
                if step not in self._pending:
                    self._pending.append(step)
            self._interrupted = self._interrupted | self._granted
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

    def _stopped_by_estop(self) -> None:
        """Take the e-stop's stop category as the last setpoints: drives at 0, the
        rotation and every other motor but the bend joints braked (their next position
        setpoint steps from where they read). The setpoints from before the e-stop were
        kept: after its reset, a drive of 0.1 m/s from standstill passed whole, its
        acceleration limit reckoned from the 0.08 m/s the wheels no longer turned at."""
        now = self.clock.now()
        for _, motor in self.robot.motors():
            if motor.function is MotorFunction.DRIVE:
                self._last_setpoint[motor.name] = (ControlMode.VELOCITY, 0.0, now)
            elif motor.function is not MotorFunction.BEND:
                self._last_setpoint.pop(motor.name, None)

    def reset_estop(self) -> bool:
        """Release a latched e-stop (operator action); the supervisor comes back in ``MANUAL``.

        The bridge may refuse (``NACK NOT_READY`` while a board is in fault or its
        hardware e-stop input is pressed) or not answer: then the e-stop stays latched,
        the refusal is logged as an error, and the operator may try again. Before
        2026-11-29 the link's error went up through the supervisor's tick and ended the
        run (and the operator console) on a link error.

        Returns:
            True when the e-stop is released (or was not latched).
        """
        with self._lock:
            self.estop_reset_refusal = None
            if self._mode is not Mode.ESTOP:
                return True
            try:
                self._port.reset_estop()
            except LinkError as exc:
                why = self._reset_refused_why(exc)
                log.error("e-stop reset refused: %s; the e-stop stays latched", why)
                self.estop_reset_refusal = why
                return False
            self._mode = Mode.MANUAL
            self._estop_reason = None
            log.warning("e-stop reset by the operator; mode manual")
            self._table_to_stop_category()
            return True

    def _table_to_stop_category(self) -> None:
        """After a reset, the setpoints the link sends (its whole table, with any next
        command) are those of the stop the bridge applied: drives at 0, the rotation and
        every other motor but the bend joints braked (PWM 0). The link kept the ones from
        before the e-stop: a camera tilt after the reset sent them, and the robot drove
        off at its old 80 mm/s (before 2026-11-30)."""
        cmds = [MotorCommand(m.name, ControlMode.VELOCITY, 0.0) for m in self.robot.drive_motors()]
        cmds += [
            MotorCommand(m.name, ControlMode.PWM, 0.0)
            for _, m in self.robot.motors()
            if m.function not in (MotorFunction.DRIVE, MotorFunction.BEND)
            and m.modes.get(ControlMode.PWM) is not None
        ]
        try:
            self._port.send(tuple(cmds))
        except LinkError as exc:
            log.error("the setpoints from before the e-stop could not be stopped: %s", exc)
            return
        now = self.clock.now()
        for c in cmds:
            self._last_setpoint[c.motor] = (c.mode, 0.0, now)

    def _reset_refused_why(self, exc: LinkError) -> str:
        """The bridge's refusal of a reset, with what the host sees of its cause (a
        bare *e-stop reset nacked NOT_READY* left the operator to guess)."""
        health = self._port.health()
        parts: list[str] = []
        if health.estop_input:
            parts.append("its hardware e-stop input is pressed")
        if health.bus_fault:
            parts.append("no board answers the bus (BUS_FAULT)")
        if health.faulted_boards:
            ids = ", ".join(str(b) for b in health.faulted_boards)
            parts.append(f"board {ids} reports FAULT")
        state = self._port.state()
        if state is not None:
            now = self.clock.now()
            away = [
                str(board)
                for board, names in sorted(self._board_readings.items())
                if names
                and board not in health.faulted_boards
                and len(stale_channels(self.robot, state, names, now)) == len(names)
            ]
            if away:
                parts.append(f"board {', '.join(away)} is not answering (every reading stale)")
        if not parts and "NOT_READY" in str(exc):
            # a board the bridge lost (TIMEOUT) before its readings here go stale
            parts.append(
                "the bridge cannot confirm every motor is held: a board not answering it"
                " (rebooting?) or in fault"
            )
        return f"{exc}: {'; '.join(parts)}" if parts else str(exc)

    # -- operator authority ---------------------------------------------------

    def set_mode(self, mode: Mode) -> None:
        """Change who is in charge; takes effect for the very next command.

        Taking over (``MANUAL``) stops the drives. Handing back (from ``MANUAL`` to
        ``AUTONOMOUS`` or ``SUPERVISED``) stops them too (the operator's speed is not the
        tree's) and leaves the safe state, as :meth:`resume` does; a change between
        ``AUTONOMOUS`` and ``SUPERVISED`` leaves it as it is. ``ESTOP`` is :meth:`estop`;
        leaving ``ESTOP`` needs :meth:`reset_estop`. A mode's text (``"estop"``) is
        that mode.

        Raises:
            InputError: ``mode`` is no mode (nothing changes).
        """
        mode = as_mode(mode)
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
            if mode is Mode.MANUAL or old is Mode.MANUAL:
                # taking over stops the tree's drives, and handing back the operator's:
                # the tree resumes from still (a drive asks again for its own speed)
                # rather than with wheels it did not set, which it counted as its own
                self._send_stop()
            if mode is Mode.AUTONOMOUS:  # no step waits for an operator there
                for step in self._pending:
                    self._decided[step] = Confirmation.GRANTED
                    self._granted.add(step)
                self._pending.clear()
            if old is Mode.MANUAL:
                # a hand-back: the operator, who had the robot, gives it back. A change
                # between autonomous and supervised is no resume: it left an operator's
                # stop (and every other cause) and let the granted steps drive on
                self._safe_reason = None
                self._safe_error = None
                self._refusals = 0
                self._node_refusals.clear()

    def resume(self) -> None:
        """Leave the safe state (operator action)."""
        with self._lock:
            if self._safe_reason is not None:
                log.warning("safe state left by the operator (was: %s)", self._safe_reason)
            self._safe_reason = None
            self._safe_error = None
            self._refusals = 0
            self._node_refusals.clear()

    def apply(self, action: OperatorAction) -> Verdict | None:
        """Apply one operator action now; returns the verdict for a command action.

        Raises:
            InputError: ``action`` is no operator action, or a ``SetMode`` of no mode
                (nothing is done; the supervisor's tick logs such an input's action
                as an error and goes on).
        """
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
                case _:
                    raise InputError(f"not an operator action: {action!r}"[:200])
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
                if step in self._pending:  # it waited in supervised mode
                    self._pending.remove(step)
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
            self._interrupted = self._interrupted - {step}
            if step in self._pending:
                self._pending.remove(step)

    def pending_confirmations(self) -> list[str]:
        """Steps waiting for the operator, oldest first."""
        return list(self._pending)

    def confirm(self, step: str | None = None) -> str | None:
        """Grant ``step`` (or the oldest pending one); returns the step granted.

        Raises:
            InputError: ``step`` is neither text nor ``None``.
        """
        return self._decide_step(step, Confirmation.GRANTED)

    def deny(self, step: str | None = None) -> str | None:
        """Deny ``step`` (or the oldest pending one); returns the step denied.

        Raises:
            InputError: ``step`` is neither text nor ``None``.
        """
        return self._decide_step(step, Confirmation.DENIED)

    def _decide_step(self, step: str | None, answer: Confirmation) -> str | None:
        if step is not None and not isinstance(step, str):
            # Deny([1]) raised TypeError out of the tick that drained it (the run ended
            # on it), Confirm(5) granted a step no node can ask for
            raise InputError(
                f"not a step: {step!r} (a step's text, or None: the oldest waiting)"[:200]
            )
        with self._lock:
            if step is None:
                if not self._pending:
                    return None
                step = self._pending[0]
            if step in self._pending:
                self._pending.remove(step)
            self._decided[step] = answer
            running = step in self._granted or step in self._interrupted
            self._interrupted = self._interrupted - {step}
            if answer is Confirmation.GRANTED:
                self._granted.add(step)
            else:
                self._granted.discard(step)
            log.warning("operator %s %r", answer, step)
            if running and answer is Confirmation.DENIED:
                # its node asked once and goes on: a drive at speed sends nothing more,
                # and went on to succeed under the operator's deny
                self.safe_state(f"the operator denied {step!r} while it ran")
            return step


def _reason_text(reason: object, what: str) -> str:
    """``reason`` as the text a safe state or an e-stop keeps: ``None`` (or no text) as
    the cause was taken for no safe state at all (``safe_state_reason`` is ``None``
    outside it): ``SafeStop(None)`` stopped the drives and the tree's next drive passed,
    and ``EStop(None)`` latched with no reason, so a primitive did not fail on it."""
    if reason is None or (isinstance(reason, str) and not reason.strip()):
        return f"{what} (no reason given)"
    return cut_reason(reason if isinstance(reason, str) else str(reason))


def as_mode(mode: object) -> Mode:
    """``mode`` as a :class:`Mode` (its text too).

    ``SetMode("estop")`` used to set the mode to the text ``"estop"``: the checks, which
    compare modes by identity, saw no e-stop and no manual control, the tree's commands
    passed, and the hand-back branch had left the safe state.

    Raises:
        InputError: it is no mode.
    """
    member = member_of(Mode, mode)
    if member is not None:
        return member
    names = ", ".join(m.value for m in Mode)
    raise InputError(f"not a mode: {mode!r} (one of {names})"[:200])
