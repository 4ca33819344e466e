"""The program's dead man's handle: a drive left turning by a program that stopped
calling in is stopped by the bridge's own watchdog.

On a wall clock a reader thread polls the link (:meth:`Session.start_reader`), so the
bridge's watchdog stays fed whatever the program does: a planner thinking for a
second between two steps, with the robot at rest, trips nothing. But a tree whose
tick blocks (a behaviour of the planner's own that sleeps or loops) with a drive set
to turn left the robot driving: nothing checked it, and the watchdog, fed by the
reader thread, never tripped (probe of 2026-11-30: a 3 s sleep beside an 80 mm/s
drive, every wheel still at 80 mm/s).

So the reader thread feeds the watchdog on its own only while no drive is set to
turn, or for :data:`HOST_SILENCE_S` after the program last called in (a
:meth:`RobotLink.poll <pirate_bt.link.robot_link.RobotLink.poll>` or ``send``, which
a supervised run makes every tick). After that its heartbeats stop, and the bridge's
watchdog stops the drives a watchdog period later (its stop category: the joints
hold, the clamps too), as it would for a host that died. Runs on a simulated clock
poll from the program itself and are not affected.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence

from pirate_bt.link.session import Session
from pirate_bt.robot.commands import CommandCodec, MotorCommand
from pirate_bt.robot.description import ControlMode, RobotDescription
from pirate_bt.robot.parts import MotorFunction

__all__ = ["HOST_SILENCE_S", "Deadman"]

_log = logging.getLogger("pirate_bt.link")

HOST_SILENCE_S = 1.0
"""How long (clock time) the reader thread goes on feeding the bridge's watchdog, with a
drive set to turn, after the program last called in: four 250 ms watchdog periods,
twenty ticks at 20 Hz."""

_TURNING_MODES = (ControlMode.VELOCITY, ControlMode.PWM)


class Deadman:
    """Which drives the setpoint table sets to turn, and the session told so.

    Args:
        robot: The robot description (its setpoint slots, in table order).
        commands: The robot's command codec (what a stop is, raw).
    """

    def __init__(self, robot: RobotDescription, commands: CommandCodec) -> None:
        self._drives = [
            (s.index, s.motor.name)
            for s in robot.setpoint_slots()
            if s.motor.function is MotorFunction.DRIVE
        ]
        self._commands = commands
        self._still: dict[tuple[int, ControlMode], int] = {}  # a stop's raw value
        self._until_s = math.inf  # the heartbeats' end last given to the session

    def turning(self, modes: Sequence[ControlMode | None], raw: Sequence[int]) -> bool:
        """Whether the table sets a drive to turn (a speed or a duty that is not 0)."""
        for index, name in self._drives:
            mode = modes[index]
            if mode is None or mode not in _TURNING_MODES:
                continue
            still = self._still.get((index, mode))
            if still is None:
                command = MotorCommand(name, mode, 0.0)
                still = self._still[(index, mode)] = self._commands.to_raw(command).raw_value
            if raw[index] != still:
                return True
        return False

    def renew(
        self, session: Session, modes: Sequence[ControlMode | None], raw: Sequence[int]
    ) -> None:
        """The program called in: feed the watchdog on its own for :data:`HOST_SILENCE_S`
        more while a drive is set to turn, for as long as it takes otherwise."""
        if not session.threaded:
            return  # the program polls: it feeds the watchdog itself, or nothing does
        now = session.clock.now()
        if now > self._until_s:
            _log.error(
                "the program did not call in for %.1f s with a drive set to turn (a blocked"
                " tick?): the link stopped feeding the bridge's watchdog after %.1f s, so"
                " that it stopped the drives",
                now - self._until_s + HOST_SILENCE_S,
                HOST_SILENCE_S,
            )
        self._until_s = now + HOST_SILENCE_S if self.turning(modes, raw) else math.inf
        session.feed_watchdog_until(self._until_s)
