"""``RobotLink``: the link seen in SI units, implementing :class:`~pirate_bt.robot.port.RobotPort`.

This is where raw integers stop. Incoming STATE frames become
:class:`~pirate_bt.robot.state.RobotState` snapshots through
:class:`~pirate_bt.robot.state.StateBuilder`; outgoing
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
from collections.abc import Sequence
from operator import attrgetter
from typing import Any

from pirate_bt.errors import LinkError
from pirate_bt.link.codec import BridgeFlags, BulkSetpoints
from pirate_bt.link.messages import BoardStatus
from pirate_bt.link.session import Outcome, Request, Session, SessionStats
from pirate_bt.robot.commands import CommandCodec, MotorCommand
from pirate_bt.robot.description import ControlMode, RobotDescription
from pirate_bt.robot.port import LinkHealth
from pirate_bt.robot.state import RobotState, StateBuilder

__all__ = ["RobotLink"]

_log = logging.getLogger(__name__)

# The session figures health() is made of, read in one C call. ``completed`` is there
# because every request that enters the loss window also bumps it, so the loss ratio
# (a sum over the window) is only recomputed when it moved.
_HEALTH_FIGURES = attrgetter(
    "_lost",
    "_closed",
    "_last_heard_s",
    "_rtt_s",
    "crc_errors",
    "retries",
    "failed",
    "duplicates",
    "completed",
    "_flags",
    "bridge_resets",
    "_faulted",
)


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
        self._states = StateBuilder(robot)
        self._commands = CommandCodec(robot)
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
        self._snapshot: RobotState | None = None
        self._snapshot_seq: int | None = None
        self._last_bulk: Request | None = None
        self._health_figures: tuple[Any, ...] | None = None
        self._health = LinkHealth(connected=False)
        self._loss_completed = -1
        self._loss_ratio = 0.0

    @property
    def robot(self) -> RobotDescription:
        """The description the link was opened with."""
        return self._robot

    def poll(self) -> None:
        """Process pending input and due retries/heartbeats without blocking.

        Raises:
            LinkLost: nothing valid heard for longer than the configured time.
        """
        if self.session.threaded:
            self.session.check_reader()
        else:
            self.session.poll()

    def state(self) -> RobotState | None:
        """The latest state snapshot, or ``None`` before the first state frame."""
        latest = self.session.latest_state()
        if latest is None:
            return None
        frame, arrived_s = latest
        if frame.seq != self._snapshot_seq:
            self._snapshot = self._states.build(frame.readings(), arrived_s, self._snapshot)
            self._snapshot_seq = frame.seq
        return self._snapshot

    def send(self, commands: Sequence[MotorCommand]) -> None:
        """Merge ``commands`` into the desired setpoints and send them in one frame.

        Does not wait for the ack (the session retries in the background of
        :meth:`poll`); use :meth:`send_and_wait` to wait.

        Raises:
            InputError: unknown motor or unsupported mode.
            LinkLost: the link is lost.
            LinkError: an earlier setpoint frame was refused or never acknowledged.
        """
        self.session.ensure_alive()
        self._settle_bulks()
        self._raise_failures()
        # every command is converted before any is merged: a call that raises changes
        # nothing, so none of its commands goes out with a later call
        raws = [self._commands.to_raw(command) for command in commands]
        away = self._boards_away()
        if away:
            # The bridge refuses a whole bulk that has an entry for a board it cannot
            # reach (BUS_ERROR, docs/protocol.md): a command for one is refused here,
            # and the others go out with that board's entries as "keep" (the bridge
            # hands the board its setpoints again when it answers).
            hit = sorted({raw.board for raw in raws} & away)
            if hit:
                raise LinkError(
                    f"board {', '.join(map(str, hit))} is not answering the bridge"
                    " (TIMEOUT: rebooting?): its setpoints cannot be delivered"
                )
        for raw in raws:
            i = self._slot_index[(raw.board, raw.slot)]
            self._modes[i] = raw.mode
            self._raw[i] = raw.raw_value
        modes = self._modes
        if away:
            modes = [None if b in away else m for b, m in zip(self._slot_board, modes, strict=True)]
        self._last_bulk = self.session.send_bulk(modes, self._raw)
        self._unsettled.append(self._last_bulk)

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

    def _boards_away(self) -> set[int]:
        """The boards the bridge's latest STATE reports in ``TIMEOUT``."""
        latest = self.session.latest_state()
        if latest is None:
            return set()
        status = latest[0].board_status
        if not any(s & BoardStatus.TIMEOUT for s in status):
            return set()
        return {b for b, s in zip(self._board_ids, status, strict=False) if s & BoardStatus.TIMEOUT}

    def send_and_wait(
        self, commands: Sequence[MotorCommand], timeout_s: float | None = None
    ) -> None:
        """Like :meth:`send`, then wait for the bridge's ack.

        Args:
            commands: Setpoints in SI units.
            timeout_s: Longest wait (default: the retry budget).

        Raises:
            LinkTimeout: no outcome within ``timeout_s``.
            LinkError: refused, failed or lost.
        """
        self.send(commands)
        assert self._last_bulk is not None
        req = self.session.wait(self._last_bulk, timeout_s)
        self._settle_bulks()
        if req.outcome is not Outcome.ACKED:
            self.session.take_failures()
            why = req.nack.name if req.nack else ""
            raise LinkError(f"setpoints not delivered: {req.outcome.value} {why}".strip())

    def _raise_failures(self) -> None:
        failures = self.session.take_failures()
        if failures:
            last = failures[-1]
            if last.nack:
                why = f"refused ({last.nack.name})"
            elif last.outcome is Outcome.STALE:
                why = "answered STALE (not applied)"
            else:
                why = "not acknowledged"
            raise LinkError(
                f"{len(failures)} earlier request(s) failed; last: {type(last.msg).__name__} "
                f"seq {last.seq} {why} after {last.tries} tries"
            )

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
            return _health_of(stats, self._board_ids_at(stats.faulted))
        # Polled session: only this thread changes the figures, so they can be read
        # without the lock and without building a SessionStats first.
        figures = _HEALTH_FIGURES(session)
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
        ) = figures
        if completed != self._loss_completed:
            recent = session._recent
            self._loss_ratio = (sum(recent) / len(recent)) if recent else 0.0
            self._loss_completed = completed
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
            estopped=bool(flags & BridgeFlags.ESTOP),
            estop_input=session._estop_input(flags),
            bridge_resets=resets,
            bus_fault=bool(flags & BridgeFlags.BUS_FAULT),
            faulted_boards=self._board_ids_at(faulted),
        )
        return self._health

    def _board_ids_at(self, positions: tuple[int, ...]) -> tuple[int, ...]:
        """Board ids at positions of the STATE frame's board order."""
        ids = self._board_ids
        return tuple(ids[i] for i in positions if i < len(ids))

    def close(self) -> None:
        """Stop the drive motors if the link still works, then release the transport."""
        stop = [
            MotorCommand(m.name, ControlMode.VELOCITY, 0.0)
            for m in self._robot.drive_motors()
            if m.modes.velocity is not None
        ]
        if stop and self.session.stats().connected:
            try:
                self.send_and_wait(stop, timeout_s=self.session.config.give_up_s)
            except LinkError as exc:
                if self.session.stats().estopped:
                    # latched: the bridge has stopped everything and refuses setpoints
                    _log.info("drives not stopped on close (the e-stop is latched): %s", exc)
                else:
                    # refused (a bus fault, a board away) or never acknowledged: the
                    # robot may be left moving; the e-stop is what the bridge always
                    # takes (it applies the stop category itself). Waited for, so the
                    # session resends a lost copy (same frame, always applied) within
                    # its retry budget; a link that fails meanwhile ends the wait.
                    _log.error("could not stop the drives on close: %s; e-stop sent", exc)
                    try:
                        self.session.wait(self.session.estop())
                    except LinkError as why:
                        _log.error("the e-stop on close was not acknowledged: %s", why)
        self.session.close()

    def __enter__(self) -> RobotLink:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _health_of(s: SessionStats, faulted_boards: tuple[int, ...]) -> LinkHealth:
    return LinkHealth(
        connected=s.connected,
        last_heard_s=s.last_heard_s,
        rtt_s=s.rtt_s,
        loss_ratio=s.loss_ratio,
        crc_errors=s.crc_errors,
        retries=s.retries,
        failed=s.failed,
        duplicates=s.duplicates,
        estopped=s.estopped,
        estop_input=s.estop_input,
        bridge_resets=s.bridge_resets,
        bus_fault=s.bus_fault,
        faulted_boards=faulted_boards,
    )
