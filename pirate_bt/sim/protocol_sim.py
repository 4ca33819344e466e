"""pyserial handler for ``sim://NAME``: a port wired to an in-process :class:`Simulator`.

pyserial imports ``protocol_<scheme>`` from every package listed in
``serial.protocol_handler_packages``; :mod:`pirate_bt.sim.simulator` adds
``pirate_bt.sim`` to that list, so ``serial.serial_for_url("sim://sim-1")``
returns this port (:class:`~pirate_bt.sim.inprocess_port.InProcessSerial`).
Writes go straight to the simulated bridge; reads take what the bridge has queued.
"""

from __future__ import annotations

from pirate_bt.sim.inprocess_port import InProcessSerial, World
from pirate_bt.sim.simulator import lookup

__all__ = ["Serial"]


class Serial(InProcessSerial):
    """A serial port whose other end is an in-process simulated PIRATEbay."""

    scheme = "sim"

    def lookup(self, name: str) -> World:
        return lookup(name)
