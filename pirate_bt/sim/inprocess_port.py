"""The pyserial port both in-process worlds share: ``sim://NAME`` and ``chain://NAME``.

pyserial imports ``protocol_<scheme>`` from every package listed in
``serial.protocol_handler_packages`` and uses its ``Serial`` class.
:mod:`pirate_bt.sim.protocol_sim` (the simulated bridge) and
:mod:`pirate_bt.sim.protocol_chain` (the bridge firmware of a chain in simavr)
each define theirs as a subclass of :class:`InProcessSerial` that names its URL
scheme and how to find the world by name. Writes go to the world's bridge; reads
take what it has queued. Reads never block: the world only moves when the shared
(virtual) clock does, so waiting here would wait for ever.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, ClassVar, Protocol
from urllib.parse import urlsplit

from serial.serialutil import PortNotOpenError, SerialBase, SerialException

if TYPE_CHECKING:
    from typing_extensions import Buffer

__all__ = ["InProcessSerial", "World"]


class World(Protocol):
    """What an in-process port needs of the world at its other end."""

    @property
    def in_waiting(self) -> int: ...

    def read(self, size: int = 1) -> bytes: ...

    def write(self, data: bytes) -> None: ...


class InProcessSerial(SerialBase):
    """A serial port whose other end is an in-process world found by its URL's name.

    Subclasses set :attr:`scheme` and :meth:`lookup`.
    """

    scheme: ClassVar[str] = ""
    """The URL scheme (``sim``, ``chain``)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        self._world: World | None = None
        super().__init__(*args, **kwargs)

    def lookup(self, name: str) -> World:
        """The world registered under ``name`` (``KeyError`` with a message if none)."""
        raise NotImplementedError

    def open(self) -> None:
        if self.port is None:
            raise SerialException("port must be configured before it can be used")
        if self.is_open:
            raise SerialException("port already open")
        self._world = self.from_url(self.portstr or "")
        self.is_open = True

    def from_url(self, url: str) -> World:
        wrong = SerialException(f"expected a {self.scheme}://NAME URL, got {url!r}")
        try:
            parts = urlsplit(url)
        except ValueError:  # "sim://[x": urlsplit says "Invalid IPv6 URL", of no NAME
            raise wrong from None
        name = parts.netloc or parts.path.lstrip("/")
        if parts.scheme != self.scheme or not name:
            raise wrong
        try:
            return self.lookup(name)
        except KeyError as exc:
            raise SerialException(str(exc.args[0])) from None

    def close(self) -> None:
        self.is_open = False
        self._world = None

    def _reconfigure_port(self) -> None:
        pass

    def _other_end(self) -> World:
        world = self._world
        if not self.is_open or world is None:
            raise PortNotOpenError()
        if getattr(world, "closed", False):
            # as a device unplugged: the world's bridge would otherwise still answer
            # writes (heartbeats acknowledged) while no clock moves it
            raise SerialException(f"{self.portstr}: the world at its other end was closed")
        return world

    @property
    def in_waiting(self) -> int:
        return self._other_end().in_waiting

    def read(self, size: int = 1) -> bytes:
        return self._other_end().read(size)

    def write(self, data: Buffer, /) -> int:
        payload = bytes(memoryview(data))
        self._other_end().write(payload)
        return len(payload)

    def reset_input_buffer(self) -> None:
        self._other_end().read(-1)

    def reset_output_buffer(self) -> None:
        pass

    def flush(self) -> None:
        pass

    def _update_break_state(self) -> None:
        pass

    def _update_rts_state(self) -> None:
        pass

    def _update_dtr_state(self) -> None:
        pass

    @property
    def cts(self) -> bool:
        return True

    @property
    def dsr(self) -> bool:
        return True

    @property
    def ri(self) -> bool:
        return False

    @property
    def cd(self) -> bool:
        return True
