"""pyserial handler for ``chain://NAME``: the host port of an in-process firmware chain.

As ``sim://`` (:mod:`pirate_bt.sim.protocol_sim`) for the simulated bridge: pyserial
imports ``protocol_chain`` from ``pirate_bt.sim`` (which :mod:`pirate_bt.sim.chain`
adds to ``serial.protocol_handler_packages``), so ``serial.serial_for_url(chain.url)``
returns this port. Writes go to the bridge firmware's USART0 (at the line's rate);
reads take what it sent. Reads never block: the chain runs in virtual time and only
moves when the shared clock does.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any
from urllib.parse import urlsplit

from serial.serialutil import PortNotOpenError, SerialBase, SerialException

from pirate_bt.sim.chain import FirmwareChain, lookup_chain

if TYPE_CHECKING:
    from typing_extensions import Buffer

__all__ = ["Serial"]


class Serial(SerialBase):
    """A serial port whose other end is the bridge firmware of an in-process chain."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        self._sim: FirmwareChain | None = None
        super().__init__(*args, **kwargs)

    def open(self) -> None:
        if self.port is None:
            raise SerialException("port must be configured before it can be used")
        if self.is_open:
            raise SerialException("port already open")
        self._sim = self.from_url(self.portstr or "")
        self.is_open = True

    def from_url(self, url: str) -> FirmwareChain:
        parts = urlsplit(url)
        if parts.scheme != "chain":
            raise SerialException(f"expected a chain://NAME URL, got {url!r}")
        name = parts.netloc or parts.path.lstrip("/")
        try:
            return lookup_chain(name)
        except KeyError as exc:
            raise SerialException(str(exc.args[0])) from None

    def close(self) -> None:
        self.is_open = False
        self._sim = None

    def _reconfigure_port(self) -> None:
        pass

    def _chain(self) -> FirmwareChain:
        if not self.is_open or self._sim is None:
            raise PortNotOpenError()
        return self._sim

    @property
    def in_waiting(self) -> int:
        return self._chain().in_waiting

    def read(self, size: int = 1) -> bytes:
        return self._chain().read(size)

    def write(self, data: Buffer, /) -> int:
        payload = bytes(memoryview(data))
        self._chain().write(payload)
        return len(payload)

    def reset_input_buffer(self) -> None:
        self._chain().read(-1)

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
