"""pyserial handler for ``chain://NAME``: the host port of an in-process firmware chain.

As ``sim://`` (:mod:`pirate_bt.sim.protocol_sim`) for the simulated bridge: pyserial
imports ``protocol_chain`` from ``pirate_bt.sim`` (which :mod:`pirate_bt.sim.chain`
adds to ``serial.protocol_handler_packages``), so ``serial.serial_for_url(chain.url)``
returns this port (:class:`~pirate_bt.sim.inprocess_port.InProcessSerial`). Writes go
to the bridge firmware's USART0 (at the line's rate); reads take what it sent. The
chain runs in virtual time and only moves when the shared clock does.
"""

from __future__ import annotations

from pirate_bt.sim.chain import lookup_chain
from pirate_bt.sim.inprocess_port import InProcessSerial, World

__all__ = ["Serial"]


class Serial(InProcessSerial):
    """A serial port whose other end is the bridge firmware of an in-process chain."""

    scheme = "chain"

    def lookup(self, name: str) -> World:
        return lookup_chain(name)
