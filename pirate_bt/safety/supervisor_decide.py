"""How the Supervisor decides on a command, records the verdict and sends a stop.

:class:`DecisionMixin` is the command side of
:class:`~pirate_bt.safety.supervisor.Supervisor`: ``_decide`` runs the six checks
in the order the supervisor's module docstring gives (authority, link,
expansion, freshness, state invariants, static limits) and sends what passes;
``_record`` numbers and stamps a verdict, keeps it, and counts repeated
refusals towards the safe state; ``_send_stop`` stops the drives.
"""

from __future__ import annotations

import logging
import math
from dataclasses import replace
from typing import TYPE_CHECKING, Any

from pirate_bt.clock import Clock
from pirate_bt.errors import LinkError, ProtocolMismatch
from pirate_bt.robot.commands import MotorCommand
from pirate_bt.robot.description import ControlMode, Half, RobotDescription
from pirate_bt.robot.port import RobotPort
from pirate_bt.robot.state import RobotState
from pirate_bt.safety.checks import (
    Check,
    CheckContext,
    HalfTarget,
    Problem,
    half_states,
    stale_channels,
)
from pirate_bt.safety.commands import Command, Stop, member_of
from pirate_bt.safety.expand import Expander
from pirate_bt.safety.limits import limit
from pirate_bt.safety.operator import Mode
from pirate_bt.safety.verdict import (
    Outcome,
    Reason,
    Source,
    Verdict,
    VerdictLog,
    current_issuer,
    node_path,
)

__all__ = ["DecisionMixin"]

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


class DecisionMixin:
    """The command side of the supervisor (mixed into ``Supervisor``)."""

    # set by the supervisor
    _port: RobotPort
    robot: RobotDescription
    clock: Clock
    verdicts: VerdictLog
    _checks: list[Check]
    _mode: Mode
    _tick: int
    _seq: int
    _safe_reason: str | None
    _safe_error: BaseException | None
    _estop_reason: str | None
    _refusals: int
    _node_refusals: dict[str, int]
    _targets: dict[Half, HalfTarget]
    _last_setpoint: dict[str, tuple[ControlMode, float, float]]
    _granted: set[str]
    _expander: Expander
    _board_readings: dict[int, tuple[str, ...]]
    _owners: dict[str, Any]
    _stop_unsent_said: bool
    # drives whose stop could not reach their board (away for good): sent again each
    # tick until it goes out, or another command for them does
    _stop_owed: frozenset[str] = frozenset()

    if TYPE_CHECKING:  # defined by the supervisor and its authority side

        @property
        def in_safe_state(self) -> bool: ...

        def safe_state(self, reason: str, *, error: BaseException | None = None) -> None: ...

        def link_problem(self) -> Problem | None: ...

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
                self._node_refusals.pop(verdict.node or "", None)
            elif verdict.reason not in _AUTHORITY:
                self._refusals += 1
                limit = self.robot.safety.max_refusals
                if self._refusals >= limit and not self.in_safe_state:
                    self.safe_state(f"{self._refusals} refused commands in a row")
                elif verdict.node is not None:
                    # one node asking again and again, between other nodes' commands that
                    # pass (a selector without memory that retries it every tick)
                    count = self._node_refusals.get(verdict.node, 0) + 1
                    self._node_refusals[verdict.node] = count
                    if count >= limit and not self.in_safe_state:
                        self.safe_state(
                            f"{count} refused commands of {verdict.node_name} ({verdict.reason}:"
                            f" {verdict.detail})"
                        )
        return verdict

    def _send_stop(self) -> tuple[MotorCommand, ...]:
        """Stop every drive, in one request; if that is refused, board by board, so that
        a board the bridge cannot reach (rebooting: its motors are off anyway) does not
        take the others' stops with it (the link refuses a setpoint for a board in
        ``TIMEOUT``, docs/protocol.md)."""
        now = self.clock.now()
        cmds = tuple(
            MotorCommand(m.name, ControlMode.VELOCITY, 0.0) for m in self.robot.drive_motors()
        )
        try:
            self._port.send(cmds)
        except LinkError as exc:
            latched = self._mode is Mode.ESTOP or self._port.health().estopped
            try:
                # the link reports an earlier request's failure before it sends (the
                # stop did not go out): those failures are taken now, so ask again
                self._port.send(cmds)
            except LinkError:
                pass
            else:
                log.warning("the stop went out at the second try (the first: %s)", exc)
                for c in cmds:
                    self._last_setpoint[c.motor] = (c.mode, 0.0, now)
                self._stop_unsent_said = False
                self._stop_owed = frozenset()
                return cmds
            by_board: dict[int, list[MotorCommand]] = {}
            for c in cmds:
                by_board.setdefault(self.robot.board_of(c.motor).id, []).append(c)
            sent: list[MotorCommand] = []
            unsent: list[str] = []
            last: LinkError = exc
            for group in by_board.values() if len(by_board) > 1 else ():
                try:
                    self._port.send(tuple(group))
                except LinkError as again:
                    unsent.extend(c.motor for c in group)
                    last = again
                    continue
                sent.extend(group)
            if not sent:
                unsent = [c.motor for c in cmds]
            # a latch has stopped every drive; otherwise a board that answers again gets
            # the setpoints its bridge kept for it, its drive's last speed among them
            self._stop_owed = frozenset() if latched else frozenset(unsent)
            if latched:
                # the bridge has stopped everything and refuses setpoints
                log.info("stop not sent (the e-stop is latched): %s", exc)
            elif unsent and isinstance(exc, ProtocolMismatch):
                # the bridge speaks another layout or protocol: no setpoint goes out, but
                # its e-stop frame reads the same whatever the layout, and the bridge
                # always takes it (the stop category: drives stopped, clamps held)
                self._port.estop()
                if not self._stop_unsent_said:
                    self._stop_unsent_said = True
                    log.error(
                        "could not send the stop of %s: %s; e-stop sent", ", ".join(unsent), exc
                    )
            elif unsent and not self._stop_unsent_said:
                # one line, once while the link stays down (a closed line gave one line
                # per drive, again at every stop sent into it)
                self._stop_unsent_said = True
                log.error("could not send the stop of %s: %s", ", ".join(unsent), last)
            cmds = tuple(sent)
        else:
            self._stop_unsent_said = False
            self._stop_owed = frozenset()
        for c in cmds:
            self._last_setpoint[c.motor] = (c.mode, 0.0, now)
        return cmds

    def _resend_owed_stop(self) -> None:
        """Send again, board by board, the stop of the drives it could not reach: the
        bridge hands a board that answers again the setpoints it keeps for it, so a
        drive whose board was away when the robot stopped went on at its last speed
        once the board was back, in the safe state (before 2026-11-30)."""
        if not self._stop_owed or self._mode is Mode.ESTOP:
            return
        by_board: dict[int, list[MotorCommand]] = {}
        for m in self.robot.drive_motors():
            if m.name in self._stop_owed:
                mc = MotorCommand(m.name, ControlMode.VELOCITY, 0.0)
                by_board.setdefault(self.robot.board_of(m.name).id, []).append(mc)
        now = self.clock.now()
        state = self._port.state()
        for board, group in by_board.items():
            names = self._board_readings.get(board, ())
            if state is None or (
                names and len(stale_channels(self.robot, state, names, now)) == len(names)
            ):
                continue  # still away (every reading stale): again next tick
            try:
                self._port.send(tuple(group))
            except LinkError as exc:
                log.info("the stop of board %d's drives not sent yet: %s", board, exc)
                continue
            motors = [c.motor for c in group]
            self._stop_owed = self._stop_owed - set(motors)
            for c in group:
                self._last_setpoint[c.motor] = (c.mode, 0.0, now)
            log.warning("the stop of %s went out (its board answers again)", ", ".join(motors))

    def _boards_not_answering(
        self, cmds: tuple[MotorCommand, ...], state: RobotState, now_s: float
    ) -> str | None:
        """Why ``cmds`` cannot reach their boards: one whose every reading is stale is
        not answering the bridge (rebooting, or gone), and the link refuses a command for
        it (``pirate_bt.link.away``), a link error; or ``None``.

        The checks above read only the channels a decision rests on (joints, springs, the
        IMU's pitch), none of them on the rotational board: a drive sent while that board
        rebooted went out to the link and ended the run on a link error (exit 3), where a
        board away ends it on stale data.
        """
        parts: list[str] = []
        boards = {self.robot.board_of(mc.motor).id for mc in cmds}
        for board in sorted(boards):
            names = self._board_readings.get(board, ())
            stale = stale_channels(self.robot, state, names, now_s) if names else []
            if names and len(stale) == len(names):
                motors = ", ".join(m.name for m in self.robot.board(board).motors)
                ages = ", ".join(
                    f"{n} ({'never' if not math.isfinite(a) else f'{a:.3f} s'})"
                    for n, a in stale[:3]
                )
                parts.append(f"board {board} ({motors}): every reading is stale: {ages}")
        if not parts:
            return None
        return f"not answering the bridge (rebooting?): {'; '.join(parts)}"

    def _motor_conflict(self, cmds: tuple[MotorCommand, ...]) -> str | None:
        """Why another tree node, still running, holds motors ``cmds`` would command: two
        primitives at once on one motor (two branches of a parallel) fight over it, each
        undoing the other's setpoint while both count it as theirs; or ``None``."""
        issuer = current_issuer()
        if issuer is None:
            return None
        owner: Any = None
        motors: list[str] = []
        for mc in cmds:
            holder = self._owners.get(mc.motor)
            if holder is None or holder is issuer or not _running(holder):
                continue
            if owner is None:
                owner = holder
            if holder is owner:
                motors.append(mc.motor)
        if owner is None:
            return None
        _, name = node_path(owner)
        drives = [m.name for m in self.robot.drive_motors()]
        shown = "the drive motors" if sorted(motors) == sorted(drives) else ", ".join(motors)
        verb = "is" if len(motors) == 1 else "are"
        return (
            f"{shown} {verb} commanded by {name}, still running: two nodes may not command"
            " the same motor at once"
        )

    def _refuse(self, command: Command, source: Source, reason: Reason, detail: str) -> Verdict:
        return Verdict(Outcome.REFUSE, command, source, reason=reason, detail=detail)

    def _decide(self, command: Command, source: Source, *, send: bool) -> Verdict:
        now = self.clock.now()
        asked = member_of(Source, source)
        if isinstance(command, Stop):
            sent = self._send_stop() if send else ()
            return Verdict(Outcome.PASS, command, asked or Source.TREE, sent=sent)
        if asked is None:
            # a source that is none of the three would have passed every authority check
            return self._refuse(
                command,
                Source.TREE,
                Reason.UNKNOWN_TARGET,
                f"not a source: {source!r} (one of {', '.join(s.value for s in Source)})",
            )
        source = asked
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
        if source is not Source.OPERATOR:
            # the tree's authority for planner code too, whatever it calls itself: the
            # supervisor's own commands (its stops, the protective clamps) never come
            # through here but as a Stop, which passed above
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
        state = self._port.state()
        expanded = self._expander.expand(command, state)
        if isinstance(expanded, Problem):
            return self._refuse(command, source, expanded.reason, expanded.detail)
        intent = expanded
        command = intent.command  # as the checks read it: Clamp("rear", ...) names Half.REAR
        if source is not Source.OPERATOR:
            conflict = self._motor_conflict(intent.motor_commands)
            if conflict is not None:
                return self._refuse(command, source, Reason.MOTOR_CONFLICT, conflict)
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
        if state is not None and intent.motor_commands:
            silent = self._boards_not_answering(intent.motor_commands, state, now)
            if silent:
                return self._refuse(command, source, Reason.STALE_STATE, silent)
        # 5. invariants
        if state is not None and intent.moves:
            ctx = CheckContext(
                self.robot,
                state,
                now,
                half_states(self.robot, state, self._targets),
                dict(self._targets),
                dict(self._last_setpoint),
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
            out.append(MotorCommand(mc.motor, mc.mode, value))
        sent = tuple(out)
        if send:
            try:
                self._port.send(sent)
            except LinkError as exc:
                self.safe_state(f"link error while sending: {exc}", error=exc)
                return self._refuse(command, source, Reason.LINK_ERROR, str(exc))
            for mc in sent:
                self._last_setpoint[mc.motor] = (mc.mode, mc.value, now)
            if self._stop_owed:  # a later command than the stop owed
                self._stop_owed = self._stop_owed - {mc.motor for mc in sent}
            issuer = current_issuer() if source is not Source.OPERATOR else None
            for mc in sent:
                self._owners[mc.motor] = issuer
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


def _running(node: Any) -> bool:
    """Whether a tree node is RUNNING (duck-typed: this layer does not import py_trees)."""
    return str(getattr(getattr(node, "status", None), "value", "")) == "RUNNING"


def board_readings(robot: RobotDescription) -> dict[int, tuple[str, ...]]:
    """Every state channel each board reports, by board id."""
    out: dict[int, list[str]] = {}
    for channel in robot.state_channels():
        out.setdefault(channel.board, []).append(channel.name)
    return {board: tuple(names) for board, names in out.items()}
