"""``RobotLink``: the link seen in SI units, implementing :class:`~pirate_bt.robot.port.RobotPort`.

This is where raw integers stop. Incoming STATE frames become
:class:`~pirate_bt.robot.state.RobotState` snapshots through
:class:`~pirate_bt.link.snapshots.Snapshots`; outgoing
:class:`~pirate_bt.robot.commands.MotorCommand` objects become raw setpoints
through :class:`~pirate_bt.robot.commands.CommandCodec` and go out as one
BULK_SETPOINTS frame carrying the full desired table (motors never commanded are
sent as "keep", with raw value 0). Because every bulk frame carries the whole table,
a newer one may replace an older one in flight without losing anything. An entry the
bridge refused (the bulk that carried it answered ``NACK``) goes back to "keep"
unless the bridge had acknowledged that very value, so no later frame, a stop above
all, carries it again (docs/protocol.md, Sequence numbers).

:func:`~pirate_bt.link.opening.open_link` and
:func:`~pirate_bt.link.opening.wrap_link` open one (the handshake, the boot latch).
"""

from __future__ import annotations

import logging
from collections.abc import Collection, Sequence
from typing import Any

from pirate_bt.errors import LinkError, LinkTimeout, ProtocolMismatch
from pirate_bt.link.away import BoardsAway, not_answering
from pirate_bt.link.closing import RequestsFailed, estop_not_taken, wait_for_estop
from pirate_bt.link.codec import BridgeFlags, BulkSetpoints, CountersRequest
from pirate_bt.link.deadman import Deadman
from pirate_bt.link.health import (
    HEALTH_FIGURES,
    REFUSED_STATES_REPORTED,
    health_of,
    lossy_text,
    refusals,
)
from pirate_bt.link.inbound import unasked_text
from pirate_bt.link.resend import BulkResends
from pirate_bt.link.session import Outcome, Request, Session
from pirate_bt.link.snapshots import AppliedSetpoints, Snapshots
from pirate_bt.robot.commands import CommandCodec, MotorCommand
from pirate_bt.robot.description import ControlMode, RobotDescription
from pirate_bt.robot.port import LinkHealth
from pirate_bt.robot.state import RobotState

__all__ = ["REFUSED_STATES_REPORTED", "RobotLink"]

_log = logging.getLogger(__name__)


class RobotLink:
    """A connected robot over the PIRATEbay protocol, in SI units (a ``RobotPort``).

    Use :func:`open_link` or :func:`wrap_link` to make one.

    Args:
        robot: The robot description.
        session: A session after a successful handshake.
    """

    def __init__(self, robot: RobotDescription, session: Session) -> None:
        self._robot = robot
        self.session = session
        self._snaps = Snapshots(robot)  # the STATEs taken, as snapshots
        self._applied = AppliedSetpoints(robot)  # what the bridge holds, by ack_seq
        self._commands = CommandCodec(robot)
        self._deadman = Deadman(robot, self._commands)  # a program that stops calling in
        slots = robot.setpoint_slots()
        self._slot_index = {(s.board, s.slot): s.index for s in slots}
        self._slot_board = [s.board for s in slots]
        self._slot_motor = [s.motor.name for s in slots]
        self._board_ids = robot.board_ids()  # the STATE frame's board order
        self._modes: list[ControlMode | None] = [None] * len(slots)
        self._raw: list[int] = [0] * len(slots)
        # what the bridge last acknowledged per motor (None: never, or only keep)
        self._acked_modes: list[ControlMode | None] = [None] * len(slots)
        self._acked_raw: list[int] = [0] * len(slots)
        self._unsettled: list[Request] = []  # bulks sent whose outcome is not yet taken in
        self._last_bulk: Request | None = None
        self._resends = BulkResends()  # a table lost on every try goes again
        self._away = BoardsAway(robot)  # boards in TIMEOUT, and commands deferred for them
        self._deferred: set[int] = set()  # the boards the last send() deferred
        self._health_figures: tuple[Any, ...] | None = None
        self._health = LinkHealth(connected=False)
        self._loss_completed = -1
        self._loss_ratio = 0.0
        self.latch_kept = ""
        """Why the latch the bridge had at the handshake stays (``LinkHealth.latch_kept``):
        set by the opener before any health is read, cleared once the latch is released
        (a health with it is built only when a figure changed: the release is one)."""
        self.close_error: LinkError | None = None
        """Set by :meth:`close` when it could not make sure the robot stopped (see there)."""

    @property
    def robot(self) -> RobotDescription:
        """The description the link was opened with."""
        return self._robot

    @property
    def readings_refused(self) -> int:
        """Fresh readings refused for a value outside their channel's raw range."""
        return self._snaps.ranges.refused

    def poll(self) -> None:
        """Process pending input and due retries/heartbeats without blocking.

        Raises:
            LinkLost: nothing valid heard for longer than the configured time.
            EStopNotTaken: an e-stop the bridge refused or never answered on every try,
                and its STATEs show no latch (raised once).
            RequestsFailed: a request given up (not a table that goes again).
        """
        if self.session.threaded:
            self.session.check_reader()
            self._deadman.renew(self.session, self._modes, self._raw)
        else:
            self.session.poll()
        if self._resends.due(self.session, self._last_bulk):
            self._send_table(self._away.by_id(self.session.boards_away()).keys())
            assert self._last_bulk is not None
            self._resends.sent(self._last_bulk)
        if self._away.owed:
            self._redeliver()
        estop = self.session.take_estop_not_taken()
        if estop is not None and not self.session.latch_reported:
            raise estop_not_taken(estop)  # once: the supervisor stops the drives
        if not self._resends.waiting(self.session, self._last_bulk):
            self._raise_failures()  # a request given up: said at once, not at a next send

    def state(self) -> RobotState | None:
        """The latest state snapshot, or ``None`` before the first state frame."""
        return self._snaps.current(self.session)

    def noise_since_state(self) -> str:
        """The unreadable frames that came since the last ``STATE`` taken, for people
        (``"15 unreadable frames (cobs 15)"``; ``""``: none): what the supervisor adds
        when no ``STATE`` came for its staleness limit while other frames did. Optional
        on a port (not in :class:`~pirate_bt.robot.port.RobotPort`); read only then."""
        return self.session.unreadable_since_state()

    def states_between(self, after: RobotState, newest: RobotState) -> tuple[RobotState, ...]:
        """Snapshots of the STATEs taken after ``after`` and before ``newest`` (two
        snapshots :meth:`state` returned), oldest first: what a 20 Hz tick reading the
        newest does not see of a 100 Hz bridge. Optional on a port (not in
        :class:`~pirate_bt.robot.port.RobotPort`); built only when asked
        (:meth:`~pirate_bt.link.snapshots.Snapshots.between`)."""
        return self._snaps.between(self.session, after, newest)

    def setpoint_applied(self, motor: str) -> MotorCommand | None:
        """The setpoint ``motor``'s board holds by the newest ``STATE``'s ``ack_seq`` (a
        superseded bulk's too), in SI; ``None`` when none is known. Optional on a port
        (not in :class:`~pirate_bt.robot.port.RobotPort`): the stalled-joint watch
        waits for a joint only once its board has the setpoint."""
        return self._applied.applied(self.session, motor)

    def boards_not_answering(self) -> tuple[int, ...]:
        """The boards the bridge's latest ``STATE`` reports in ``TIMEOUT`` (not answering
        it: a reboot, a lost reply), by id: what the supervisor names when their readings
        go stale. Optional on a port (not in :class:`~pirate_bt.robot.port.RobotPort`);
        read only then, not every tick."""
        return tuple(sorted(self._away.by_id(self.session.boards_away())))

    def send(self, commands: Sequence[MotorCommand]) -> None:
        """Merge ``commands`` into the desired setpoints and send them in one frame.

        Does not wait for the ack (the session retries in the background of
        :meth:`poll`); use :meth:`send_and_wait` to wait. A command for a board the
        bridge reports in ``TIMEOUT`` waits in the table until the board is back, and
        :meth:`poll` sends it then (:mod:`pirate_bt.link.away`).

        Raises:
            InputError: unknown motor or unsupported mode.
            LinkLost: the link is lost.
            LinkError: an earlier setpoint frame was refused or never acknowledged, or
                a command is for a board away for longer than its readings stay fresh.
        """
        self.session.ensure_alive()
        self._settle_bulks()
        self._raise_failures()
        # every command is converted before any is merged: a call that raises changes
        # nothing, so none of its commands goes out with a later call
        raws = [self._commands.to_raw(command) for command in commands]
        away = self._away.by_id(self.session.boards_away())
        deferred: set[int] = set()
        if away:
            # The bridge refuses a whole bulk that has an entry for a board it cannot
            # reach (BUS_ERROR, docs/protocol.md): that board's entries go out as keep.
            # A command for it waits in the table for the board's return (away.py); one
            # for a board away for longer than its grace is refused here.
            deferred = {raw.board for raw in raws} & away.keys()
            late = self._overdue(away, deferred)
            if late:
                raise LinkError(not_answering(late, "cannot be delivered"))
        for raw in raws:
            i = self._slot_index[(raw.board, raw.slot)]
            self._modes[i] = raw.mode
            self._raw[i] = raw.raw_value
        # the table goes out whole: boards back since are served by this frame
        self._away.owed = (self._away.owed & away.keys()) | deferred
        self._deferred = deferred
        self._send_table(away.keys())
        self._deadman.renew(self.session, self._modes, self._raw)

    def _overdue(self, away: dict[int, float], boards: set[int]) -> list[tuple[int, float, bool]]:
        """Those of ``boards`` away with every reading stale (:mod:`pirate_bt.link.away`)."""
        if not boards & away.keys():
            return []
        latest = self.session.latest_state()
        at_s = latest[1] if latest is not None else self.session.clock.now()
        return self._away.overdue(away, boards, self._snaps.snapshot, at_s)

    def _send_table(self, away: Collection[int]) -> None:
        """Send the whole table, the entries of the boards in ``away`` as keep."""
        modes = self._modes
        if away:
            modes = [None if b in away else m for b, m in zip(self._slot_board, modes, strict=True)]
        self._last_bulk = self.session.send_bulk(modes, self._raw)
        self._unsettled.append(self._last_bulk)
        assert isinstance(self._last_bulk.msg, BulkSetpoints)
        self._applied.sent(self._last_bulk.msg)

    def _redeliver(self) -> None:
        """Send the table again when a board with a deferred command is back."""
        away = self._away.by_id(self.session.boards_away())
        back = self._away.owed - away.keys()
        if not back:
            return
        self._away.owed -= back
        if self.session.stats().estopped:
            return  # latched: the bridge refuses setpoints; the reset is the operator's
        _log.info("board %s answers again: its deferred setpoints go out", sorted(back))
        self._send_table(away.keys())

    def _wait_deferred(self, deferred: set[int], timeout_s: float | None) -> None:
        """Wait until the boards of ``deferred`` are back and the table that carries
        their setpoints is acknowledged, or one is away for good (:mod:`.away`).

        Raises:
            LinkError: a board stayed away, the e-stop latched meanwhile, or the table
                was not acknowledged.
            LinkTimeout: still waiting after ``timeout_s`` (default: the longest
                freshness limit and a request's retry budget).
        """
        clock, config = self.session.clock, self.session.config
        wait_s = self._away.longest_grace_s + config.give_up_s if timeout_s is None else timeout_s
        deadline = clock.now() + wait_s
        sent = self._last_bulk
        while deferred & self._away.owed:
            away = self._away.by_id(self.session.boards_away())
            late = self._overdue(away, deferred & self._away.owed)
            if late:
                raise LinkError(not_answering(late, "were not delivered"))
            if clock.now() >= deadline:
                raise LinkTimeout(
                    f"board {', '.join(map(str, sorted(deferred)))} did not answer the bridge"
                    f" again within {wait_s:.3f} s: its setpoints were not delivered"
                )
            clock.sleep(config.poll_step_s)
            self.poll()
        if self._last_bulk is sent:  # back, but not sent again: the e-stop latched
            raise LinkError("setpoints not delivered: the e-stop latched while the board was away")
        assert self._last_bulk is not None
        self._check_delivered(self.session.wait(self._last_bulk))

    def _settle_bulks(self) -> None:
        """Take the outcomes of the bulks sent into the table.

        An acknowledged bulk's entries are what the bridge holds. A refused one changed
        nothing on the bridge (all or nothing): each of its entries that differs from
        what the bridge last acknowledged, and is still in the table, goes back to keep,
        so that the next frame (a stop above all) does not carry a setpoint the bridge
        refused, and is not refused for it again when the refusal is permanent
        (``BAD_MODE``, ``OUT_OF_RANGE``). Keep, not the acknowledged value: after an
        e-stop or a watchdog trip the bridge holds its stop, and an older acknowledged
        value must not restart a motor. Bulks that failed, went stale or were
        superseded or cancelled leave the table as it is.
        """
        if not self._unsettled:
            return
        pending: list[Request] = []
        for req in self._unsettled:
            msg = req.msg
            if not req.done or not isinstance(msg, BulkSetpoints):
                pending.append(req)
                continue
            if req.outcome is Outcome.ACKED:
                for i, mode in enumerate(msg.modes):
                    if mode is not None:
                        self._acked_modes[i] = mode
                        self._acked_raw[i] = msg.raw_values[i]
            elif req.outcome is Outcome.NACKED:
                self._revert(msg, req.nack.name if req.nack else "")
        self._unsettled = pending

    def _revert(self, refused: BulkSetpoints, why: str) -> None:
        acked_modes, acked_raw = self._acked_modes, self._acked_raw
        reverted: list[str] = []
        for i, (mode, raw) in enumerate(zip(refused.modes, refused.raw_values, strict=True)):
            if mode is None or (mode is acked_modes[i] and raw == acked_raw[i]):
                continue  # keep, or a value the bridge holds
            if self._modes[i] is mode and self._raw[i] == raw:
                self._modes[i] = None
                self._raw[i] = 0
                reverted.append(self._slot_motor[i])
        if reverted:
            _log.info(
                "setpoints seq %d refused (%s): %s back to keep",
                refused.seq,
                why,
                ", ".join(reverted),
            )

    def send_and_wait(
        self, commands: Sequence[MotorCommand], timeout_s: float | None = None
    ) -> None:
        """Like :meth:`send`, then wait for the bridge's ack.

        A command for a board the bridge reports in ``TIMEOUT`` is waited for until the
        board is back and its setpoints are acknowledged, or it is away for good
        (:mod:`pirate_bt.link.away`).

        Args:
            commands: Setpoints in SI units.
            timeout_s: Longest wait for each of the two (default: the retry budget, and
                the longest freshness limit and the retry budget).

        Raises:
            LinkTimeout: no outcome within ``timeout_s``.
            LinkError: refused, failed or lost.
        """
        self.send(commands)
        deferred = self._deferred
        assert self._last_bulk is not None
        self._check_delivered(self.session.wait(self._last_bulk, timeout_s))
        if deferred:
            self._wait_deferred(deferred, timeout_s)

    def _check_delivered(self, req: Request) -> None:
        self._settle_bulks()
        if req.outcome is not Outcome.ACKED:
            self.session.take_failures()
            why = req.nack.name if req.nack else ""
            raise LinkError(f"setpoints not delivered: {req.outcome.value} {why}".strip())

    def _raise_failures(self) -> None:
        # A counters request's failure is its own outcome (the caller waits on it): it
        # says nothing of the setpoints, so it must not refuse them (docs/protocol.md)
        failures = [
            r for r in self.session.take_failures() if not isinstance(r.msg, CountersRequest)
        ]
        if failures:
            last = failures[-1]
            if last.nack:
                why = f"refused ({last.nack.name})"
            elif last.outcome is Outcome.STALE:
                why = "answered STALE (not applied)"
            else:
                why = "not acknowledged"
            hint = (
                ""
                if last.nack or last.outcome is Outcome.STALE
                else self._one_way_hint(last.first_sent_s, last)
            )
            raise RequestsFailed(
                f"{len(failures)} earlier request(s) failed; last: {type(last.msg).__name__} "
                f"seq {last.seq} {why} after {last.tries} tries{hint}"
            )

    def _one_way_hint(self, since_s: float | None = None, req: Request | None = None) -> str:
        """Why a request first sent at ``since_s`` went unanswered, when the bridge's own
        frames tell: its watchdog tripped (it heard nothing from the host), it answered
        meanwhile requests the host never made (it hears the host, but answers with
        another seq or type: before 2026-11-30 such a bridge was asked *does it hear the
        host?*), the line lost frames while ``req`` was tried (the bridge answered some of
        the host's heartbeats, so it hears the host: :func:`lossy_text`; before
        2026-12-01 a request lost on every try of a lossy line was asked *does it hear
        the host?* too), or its STATEs still arrive (the line from the bridge works; the
        one toward it may not). ``""`` when they tell nothing."""
        if self.session.stats().watchdog:
            return (
                ": the bridge reports its watchdog tripped (it hears nothing from the host:"
                " the line toward the bridge is down?)"
            )
        unasked = 0 if since_s is None else self.session.answers_unasked_since(since_s)
        if unasked:
            return f", though the bridge {unasked_text(unasked)}"
        lossy = "" if req is None else lossy_text(self.session, req.marks)
        if lossy:
            return lossy
        latest = self.session.latest_state()
        if (
            latest is not None
            and self.session.clock.now() - latest[1] < self.session.config.ack_timeout_s
        ):
            return ", though the bridge's STATE frames still arrive (does it hear the host?)"
        return ""

    def estop(self) -> None:
        """Send an e-stop ahead of every queue; never raises for a busy link."""
        try:
            self.session.estop()
        except LinkError as exc:  # e.g. closed: nothing more can be done here
            _log.error("e-stop not sent: %s", exc)

    def reset_estop(self) -> None:
        """Release a latched e-stop on the bridge and wait for the ack.

        Raises:
            LinkError: the bridge refused or did not answer.
        """
        req = self.session.wait(self.session.estop_reset())
        self.session.take_failures()
        if req.outcome is not Outcome.ACKED:
            why = req.nack.name if req.nack else ""
            raise LinkError(f"e-stop reset {req.outcome.value} {why}".strip())

    def health(self) -> LinkHealth:
        """Current link figures.

        Read every tick by the supervisor and the trace, so it is cheap: while no
        figure changed the same (immutable) ``LinkHealth`` is returned again, and a
        caller may compare with ``is`` to skip its own diffing. A changed figure always
        gives a new object; nothing is cached across a change.
        """
        session = self.session
        if session.threaded:
            # A reader thread mutates the session: take its consistent, locked snapshot.
            stats = session.stats()
            if not stats.estopped:
                self.latch_kept = ""  # released since, as below (it was left out here)
            faulted = self._board_ids_at(stats.faulted)
            taken = session.latest_state() is not None
            return health_of(stats, faulted, session.refused_states(), self.latch_kept, taken=taken)
        # Polled session: only this thread changes the figures, so they can be read
        # without the lock and without building a SessionStats first.
        # The line's noise since the last good frame is not a counter the figures hold
        # (an echo, bytes without a delimiter): it is read with them.
        figures = (*HEALTH_FIGURES(session), session.line_noise())
        if figures == self._health_figures:
            return self._health
        (
            lost,
            closed,
            heard_s,
            rtt_s,
            crc,
            retries,
            failed,
            dups,
            completed,
            flags,
            resets,
            faulted,
            refused,
            noise,
        ) = figures
        if completed != self._loss_completed:
            recent = session._recent
            self._loss_ratio = (sum(recent) / len(recent)) if recent else 0.0
            self._loss_completed = completed
        estopped = session._estopped(flags)
        if not estopped:
            self.latch_kept = ""  # released since: a later latch has causes of its own
        self._health_figures = figures
        self._health = LinkHealth(
            connected=not (lost or closed),
            last_heard_s=heard_s,
            rtt_s=rtt_s,
            loss_ratio=self._loss_ratio,
            crc_errors=crc,
            retries=retries,
            failed=failed,
            duplicates=dups,
            estopped=estopped,
            estop_input=session._estop_input(flags),
            bridge_resets=resets,
            bus_fault=bool(flags & BridgeFlags.BUS_FAULT),
            faulted_boards=self._board_ids_at(faulted),
            states_refused=refusals(refused, taken=session.latest_state() is not None),
            line_noise=noise,
            latch_kept=self.latch_kept,
        )
        return self._health

    def _board_ids_at(self, positions: tuple[int, ...]) -> tuple[int, ...]:
        """Board ids at positions of the STATE frame's board order."""
        ids = self._board_ids
        return tuple(ids[i] for i in positions if i < len(ids))

    def close(self) -> None:
        """Stop the drive motors if the link still works, then release the transport.

        Never raises. When neither the stop nor the e-stop sent after it is acknowledged,
        the robot may be left moving until the bridge's watchdog stops it:
        :attr:`close_error` then says so (a :class:`LinkError`), for the run's result.
        """
        stop = [
            MotorCommand(m.name, ControlMode.VELOCITY, 0.0)
            for m in self._robot.drive_motors()
            if m.modes.velocity is not None
        ]
        if stop and self.session.stats().connected:
            before = self._last_bulk
            self._settle_bulks()
            try:
                # an earlier request's failure (no later send raised it) is not the
                # stop's: it must not keep the stop from going out, nor latch the e-stop
                self._raise_failures()
            except LinkError as exc:
                _log.warning("on close: %s", exc)
            try:
                self.send_and_wait(stop, timeout_s=self.session.config.give_up_s)
            except LinkError as exc:
                if self.session.latch_reported:
                    # latched: the bridge has stopped everything and refuses setpoints
                    _log.info("drives not stopped on close (the e-stop is latched): %s", exc)
                else:
                    # refused (a bus fault, a board away) or never acknowledged: the
                    # robot may be left moving; the e-stop is what the bridge always
                    # takes (it applies the stop category itself). Waited for, so the
                    # session resends a lost copy (same frame, always applied) within
                    # its retry budget; a link that fails meanwhile ends the wait.
                    _log.error("could not stop the drives on close: %s; e-stop sent", exc)
                    bulk = self._last_bulk
                    self._estop_on_close(exc, None if bulk is before else bulk)
        self.session.close()

    def _estop_on_close(self, stop_error: LinkError, bulk: Request | None) -> None:
        """Send the close's e-stop and wait for it; keep in :attr:`close_error` why the
        robot may still be moving when it is not acknowledged (``bulk``: the stop's
        frame, ``None`` when none went out)."""
        # the wait for the stop ends with its retry budget, as its last try goes unanswered
        # (then the e-stop cancels it): never acknowledged, as much as one given up
        unanswered = (
            isinstance(stop_error, LinkTimeout)
            and bulk is not None
            and bulk.outcome is Outcome.PENDING
        )
        try:
            req = wait_for_estop(self.session, self.session.estop())
        except ProtocolMismatch as why:  # named once when the stop's cause too
            said = "" if str(why) in str(stop_error) else f" ({why})"
            estop = f"and the e-stop sent after it was not answered either{said}"
        except LinkTimeout:
            # its wait (its retry budget) ended before the poll that gives it up (a reader
            # thread that polled late, on a flooded line): never acknowledged, as much as
            # one given up (before 2026-11-30: "... failed (Request(EStop seq=10 pending)
            # not answered within 0.240 s)")
            estop = "nor was the e-stop sent after it"
        except LinkError as why:
            # lost as the bridge reported it hears nothing from the host: said below
            deaf = self.session._lost_why and self.session.stats().watchdog
            estop = (
                "nor was the e-stop sent after it"
                if deaf
                else f"and the e-stop sent after it failed ({why})"
            )
        else:
            if req.outcome is Outcome.ACKED:  # said, after the stop's failure was logged
                _log.warning("the e-stop sent on close was acknowledged: the drives stopped")
                return
            if req.outcome is Outcome.FAILED:
                estop = "nor was the e-stop sent after it"
            else:
                estop = f"and the e-stop sent after it was {req.outcome.value}"
        if bulk is not None and bulk.outcome is Outcome.NACKED and bulk.nack is not None:
            stop = f"refused ({bulk.nack.name})"
        elif bulk is not None and (bulk.outcome is Outcome.FAILED or unanswered):
            stop = "never acknowledged"
        else:
            stop = f"not confirmed ({stop_error})"
        # the bridge's own frames may tell that the line toward it is down, and that its
        # watchdog has stopped the drives already (docs/protocol.md, Faults on the line)
        if self.session.stats().watchdog:
            after = (
                ": the bridge reports its watchdog tripped, so its drives are stopped (it"
                " hears nothing from the host: the line toward the bridge is down?)"
            )
        else:
            after = (
                f"{self._one_way_hint(None if bulk is None else bulk.first_sent_s, bulk)}: the"
                " robot may still be moving until its bridge's watchdog stops it"
            )
        self.close_error = LinkError(f"the closing stop was {stop}, {estop}{after}")
        _log.error("%s", self.close_error)

    def __enter__(self) -> RobotLink:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
