"""pyserial handler for ``sim://NAME``: a port wired to an in-process :class:`Simulator`.

pyserial imports ``protocol_<scheme>`` from every package listed in
``serial.protocol_handler_packages``; :mod:`pirate_bt.sim.simulator` adds
``pirate_bt.sim`` to that list, so ``serial.serial_for_url("sim://sim-1")``
returns this port. Writes go straight to the simulated bridge; reads take what
the bridge has queued. Reads never block: the simulated world only moves when
the shared clock does, so waiting here would wait for ever.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any
from urllib.parse import urlsplit

from serial.serialutil import PortNotOpenError, SerialBase, SerialException

from pirate_bt.sim.simulator import Simulator, lookup

if TYPE_CHECKING:
    from typing_extensions import Buffer

__all__ = ["Serial"]


class Serial(SerialBase):
    """A serial port whose other end is an in-process simulated PIRATEbay."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        self._sim: Simulator | None = None
        super().__init__(*args, **kwargs)

    def open(self) -> None:
        if self.port is None:
            raise SerialException("port must be configured before it can be used")
        if self.is_open:
            raise SerialException("port already open")
        self._sim = self.from_url(self.portstr or "")
        self.is_open = True

    def from_url(self, url: str) -> Simulator:
        parts = urlsplit(url)
        if parts.scheme != "sim":
            raise SerialException(f"expected a sim://NAME URL, got {url!r}")
        name = parts.netloc or parts.path.lstrip("/")
        try:
            return lookup(name)
        except KeyError as exc:
            raise SerialException(str(exc.args[0])) from None

    def close(self) -> None:
        self.is_open = False
        self._sim = None

    def _reconfigure_port(self) -> None:
        pass

    def _simulator(self) -> Simulator:
        if not self.is_open or self._sim is None:
            raise PortNotOpenError()
        return self._sim

    @property
    def in_waiting(self) -> int:
        return self._simulator().in_waiting

    def read(self, size: int = 1) -> bytes:
        return self._simulator().read(size)

    def write(self, data: Buffer, /) -> int:
        payload = bytes(memoryview(data))
        self._simulator().write(payload)
        return len(payload)

    def reset_input_buffer(self) -> None:
        self._simulator().read(-1)

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
