"""The port as the layers above the supervisor see it: read, never command.

:attr:`~pirate_bt.safety.supervisor.Supervisor.port` hands this view out, so that a
behaviour or planner code reading the robot's state cannot reach the link's ``send``
(split out of :mod:`pirate_bt.safety.supervisor`, unchanged).
"""

from __future__ import annotations

from pirate_bt.robot.description import RobotDescription
from pirate_bt.robot.port import LinkHealth, RobotPort
from pirate_bt.robot.state import RobotState

__all__ = ["PortView"]


class PortView:
    """A robot port as the layers above the supervisor may use it: read, never command.

    It has the port's ``robot``, ``state()``, ``health()`` and ``poll()`` (a loop that
    waits without ticking the supervisor polls through it); ``send``, ``estop``,
    ``reset_estop``, ``close`` and the link's own objects are not there: a command goes
    through the supervisor's checks, an e-stop through :meth:`Supervisor.estop`.
    """

    __slots__ = ("__port",)

    def __init__(self, port: RobotPort) -> None:
        self.__port = port

    @property
    def robot(self) -> RobotDescription:
        return self.__port.robot

    def poll(self) -> None:
        """Read what the link has received (see :meth:`RobotPort.poll`)."""
        self.__port.poll()

    def state(self) -> RobotState | None:
        return self.__port.state()

    def health(self) -> LinkHealth:
        return self.__port.health()

    def __getattr__(self, name: str) -> object:
        raise AttributeError(
            f"the supervisor's port is read-only: no {name!r} (commands go through"
            " supervisor.command(), an e-stop through supervisor.estop())"
        )

    def __repr__(self) -> str:
        return f"<read-only view of {type(self.__port).__name__}>"
