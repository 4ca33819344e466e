"""Probe 22: a host that opens the simulator's pty resets its bridge, as a real port does.

docs/protocol.md (Line): opening the bridge's serial port toggles DTR, which resets the
Arduino; the host waits, then says HELLO to a bridge that booted latched, and releases
that boot latch. ``pirate-bt sim --firmware`` (the firmware in simavr) does so on its pty.
``pirate-bt sim --pty``, which a host opens "like the USB serial port of a real
PIRATEbay", did not: the second host found the first one's session (``sessions`` 2, the
same boot id) and its latch as an earlier session's, so a run after a teleop session
that ended on an e-stop was refused (*latched in an earlier session (reset it)*) where
on the robot, and through ``sim --firmware``, it starts. A host that falls away mid-frame
left its half frame for the next host's first frame, too. What is checked is the bytes on
the pty: the second open meets a fresh boot.
"""

from __future__ import annotations

import contextlib
import os
import struct
import time
import tty
from collections.abc import Callable

from cleanroom_peer import (
    ACK,
    ESTOP,
    ESTOP_RESET,
    F_ESTOP,
    HELLO,
    HELLO_REPLY,
    Decoder,
    Frame,
    frame,
    layout_of,
    parse_hello_reply,
)

from pirate_bt.robot import load_robot
from pirate_bt.sim import Simulator
from pirate_bt.sim.server import SimServer

ROBOT = load_robot()
LAYOUT = layout_of(ROBOT)


def _answer(fd: int, decoder: Decoder, kind: int, request: bytes, seq: int) -> Frame:
    """Send ``request`` (seq ``seq``) and the bridge's answer of ``kind`` to it: the same
    frame again every second, as a host retries, for up to 20 s (a loaded machine)."""
    deadline = time.monotonic() + 20.0
    resend = 0.0
    while time.monotonic() < deadline:
        if time.monotonic() >= resend:
            os.write(fd, request)
            resend = time.monotonic() + 1.0
        try:
            data = os.read(fd, 4096)
        except BlockingIOError:
            time.sleep(0.005)
            continue
        for item in decoder.feed(data):
            if isinstance(item, Frame) and item.kind == kind and item.seq == seq:
                return item
    raise AssertionError(f"no answer of type {kind:#x} to seq {seq} within 20 s")


def _until(condition: Callable[[], bool], what: str) -> None:
    deadline = time.monotonic() + 20.0
    while not condition():
        assert time.monotonic() < deadline, f"not within 20 s: {what}"
        time.sleep(0.01)


def _connection(device: str, *, half_frame: bool = False) -> Frame:
    """Open the pty, HELLO; release the latch and latch it again (an operator's e-stop);
    close (mid-frame, with ``half_frame``). The HELLO_REPLY."""
    fd = os.open(device, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
    try:
        tty.setraw(fd)
        decoder = Decoder()
        # no leading 0x00: a host need not flush (docs/protocol.md, Framing: "may")
        hello = frame(HELLO, 1, struct.pack("<IB", LAYOUT.digest, 2))
        reply = _answer(fd, decoder, HELLO_REPLY, hello, 1)
        _answer(fd, decoder, ACK, frame(ESTOP_RESET, 2), 2)
        _answer(fd, decoder, ACK, frame(ESTOP, 3), 3)
        if half_frame:
            os.write(fd, frame(ESTOP_RESET, 4)[:5])
        return reply
    finally:
        with contextlib.suppress(OSError):
            os.close(fd)


def test_opening_the_simulators_pty_resets_its_bridge_as_a_real_port_does() -> None:
    with Simulator("straight", ROBOT) as sim:
        server = SimServer(sim)
        device = server.open_pty()
        server.start()
        try:
            first = _connection(device, half_frame=True)
            _until(lambda: not server.host_connected, "the server sees the first host leave")
            second = _connection(device)
        finally:
            server.stop()
    one, two = parse_hello_reply(first.payload), parse_hello_reply(second.payload)
    assert one["sessions"] == 1
    # a fresh boot: its first session, another boot id, latched from boot (not the first
    # host's e-stop of an earlier session)
    assert two["sessions"] == 1, (one, two)
    assert two["boot_id"] != one["boot_id"], (one, two)
    assert second.arg & F_ESTOP
