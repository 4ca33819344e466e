"""Probe 21: a host that writes faster than the line, through the firmware's simulators.

A serial line never loses a byte to a host that writes faster than its baud rate: the
host's write waits (the driver's and the adapter's buffers fill, then the write blocks)
and the bytes go out at the line's rate, in order. The two harnesses that put the
bridge firmware behind a port did not: the whole chain (``pirate-chain``, reached
through ``chain://``) overwrote its 64 KB queue to the bridge's USART0, so the bridge
heard frames from later in the stream spliced into earlier ones, and a write of more
than 64 KB between two steps raised ``struct.error`` out of the port; ``pirate-simavr``
(``pirate-bt sim --firmware``) threw away what did not fit its queue
(``host_bytes_dropped``).
"""

from __future__ import annotations

import contextlib
import os
import select
import time

import pytest
from cleanroom_peer import (
    APPLIED,
    BRIDGE_HEARTBEAT,
    ESTOP_RESET,
    HEARTBEAT,
    HELLO_REPLY,
    KEEP,
    MODE_CODES,
    STATE,
    Decoder,
    Frame,
    Layout,
    bulk,
    frame,
    hello,
    layout_of,
)
from firmware_chain_support import missing_chain, open_chain
from firmware_sim_support import HostEnd, build, missing_toolchain

from pirate_bt.link.messages import Ack
from pirate_bt.pipes import load_network
from pirate_bt.robot import load_robot
from pirate_bt.sim.chain import FirmwareChain
from pirate_bt.sim.firmware_bridge import FirmwareBridge
from pirate_bt.sim.model import PipeRobotModel

ROBOT = load_robot()
LAYOUT: Layout = layout_of(ROBOT)
STOPPED = [
    (MODE_CODES["velocity"], 0) if role == "drive" else (KEEP, 0) for *_, role, _ in LAYOUT.motors
]
BULK_WIRE = len(bulk(3, STOPPED))
LINE_BYTES_PER_S = 11_520  # 115200 baud, 8N1

needs_chain = pytest.mark.skipif(
    missing_chain() is not None, reason=f"the chain in simavr: {missing_chain()}"
)
needs_simavr = pytest.mark.skipif(
    missing_toolchain() is not None, reason=f"simavr: {missing_toolchain()}"
)


class ChainHost:
    """The chain's host port, spoken to by the clean-room peer, on the chain's own time."""

    def __init__(self, chain: FirmwareChain) -> None:
        self.chain = chain
        self.decoder = Decoder()
        self.states: list[Frame] = []
        self.errors: list[str] = []

    def step(self, data: bytes = b"", dt: float = 0.02) -> list[Frame]:
        if data:
            self.chain.write(data)
        self.chain.advance_to(self.chain.cycle / 16e6 + dt)
        answers = []
        for item in self.decoder.feed(self.chain.read()):
            if isinstance(item, str):
                self.errors.append(item)
            elif item.kind in (STATE, BRIDGE_HEARTBEAT):
                self.states.append(item)
            else:
                answers.append(item)
        return answers

    def session(self) -> None:
        self.step(dt=0.05)  # the firmware's start-up: bytes before its USART is on are lost
        assert [a.kind for a in self.step(hello(1, LAYOUT), 0.03)] == [HELLO_REPLY]
        released = self.step(frame(ESTOP_RESET, 2), 0.03)
        assert [a.payload for a in released] == [bytes([ESTOP_RESET, APPLIED])]

    def acked(self) -> list[int]:
        """The ``ack_seq`` of every STATE so far: the last bulk applied."""
        return [LAYOUT.parse_state(s.payload)[0] for s in self.states if s.kind == STATE]


def bulks(first: int, count: int) -> bytes:
    return b"".join(bulk(seq, STOPPED) for seq in range(first, first + count))


def in_order(acked: list[int], first: int, fed_bytes: float) -> None:
    """Every bulk applied in the order written: ``ack_seq`` never goes back and never
    names a bulk the line cannot have carried yet."""
    seen = [a for a in acked if a]
    assert seen == sorted(seen), seen
    most = first + int(fed_bytes / BULK_WIRE) + 1
    assert seen and seen[-1] <= most, f"bulk {seen[-1]} applied, at most {most} carried: {seen}"


@needs_chain
def test_the_chain_feeds_a_host_faster_than_the_line_in_order_and_whole() -> None:
    with open_chain() as (chain, _clock):
        host = ChainHost(chain)
        host.session()
        # 74 KB of bulks (6.4 s of the line) written in two goes a millisecond apart
        half = 650
        host.step(bulks(3, half), dt=0.001)
        host.step(bulks(3 + half, half), dt=0.3)
        in_order(host.acked(), 3, 0.31 * LINE_BYTES_PER_S)
        assert host.errors == []


@needs_chain
def test_the_chain_takes_more_than_64_kb_written_at_once() -> None:
    with open_chain() as (chain, _clock):
        host = ChainHost(chain)
        host.session()
        many = 1200  # 68 KB in one write, more than one record to the harness can carry
        host.step(bulks(3, many), dt=0.2)
        in_order(host.acked(), 3, 0.21 * LINE_BYTES_PER_S)
        assert host.errors == []


@needs_simavr
def test_the_simavr_harness_makes_a_host_faster_than_the_line_wait_not_lose_bytes() -> None:
    elf, harness = build()
    bridge = FirmwareBridge(
        elf, PipeRobotModel(ROBOT, load_network("straight")), harness=harness, boot_ms=0
    )
    try:
        host = HostEnd(bridge.start(), ROBOT)  # the open resets the MCU
        bridge.wait_resets(1)
        time.sleep(0.05)
        assert host.hello() is not None
        data = bulks(3, 1400)  # 80 KB: 7 s of the line, more than the harness queues
        os.set_blocking(host.fd, False)
        deadline = time.monotonic() + 60
        view = memoryview(data)
        while view and time.monotonic() < deadline:
            if select.select([], [host.fd], [], 0.1)[1]:
                with contextlib.suppress(BlockingIOError):
                    view = view[os.write(host.fd, view) :]
            while select.select([host.fd], [], [], 0)[0]:
                os.read(host.fd, 65536)  # the bridge's STATEs, not read here
        assert not view, f"{len(view)} bytes never taken in 60 s"
        figures = bridge.figures()
        assert figures["host_bytes_dropped"] == 0, figures
        assert figures["unexpected_resets"] == 0
        os.close(host.fd)
    finally:
        bridge.close()


@needs_simavr
def test_what_a_closed_host_left_unsent_never_reaches_the_next_boot() -> None:
    """A serial port closed with bytes still waiting loses them with the DTR reset of
    the next open; the harness's back-pressure must not hand them to the next boot."""
    elf, harness = build()
    bridge = FirmwareBridge(
        elf, PipeRobotModel(ROBOT, load_network("straight")), harness=harness, boot_ms=0
    )
    try:
        device = bridge.start()
        first = HostEnd(device, ROBOT)
        bridge.wait_resets(1)
        os.set_blocking(first.fd, False)
        data = memoryview(b"".join(frame(HEARTBEAT, seq) for seq in range(1, 9000)))  # 80 KB
        deadline = time.monotonic() + 60
        while data and time.monotonic() < deadline:
            if select.select([], [first.fd], [], 0.1)[1]:
                with contextlib.suppress(BlockingIOError):
                    data = data[os.write(first.fd, data) :]
            if bridge.figures()["host_queue_bytes"] >= 60_000:
                break  # the harness's queue is full: the rest waits in the pty
        # every byte the harness took so far went to the first boot (or was lost with it)
        taken = int(bridge.figures()["host_bytes_in"])
        os.close(first.fd)
        time.sleep(0.2)
        second = HostEnd(device, ROBOT)  # the open resets the MCU
        bridge.wait_resets(2)
        heard = second.read(1.5)  # the second host sends nothing
        beat = len(frame(HEARTBEAT, 1))  # 9 bytes, whatever the seq
        late = [m.seq for m in heard if isinstance(m, Ack) and m.seq > taken // beat + 1]
        assert late == [], (
            f"{len(late)} heartbeats the first host wrote before it closed were answered"
            f" after (seq {late[0]} to {late[-1]}; the first boot took {taken // beat})"
        )
        os.close(second.fd)
    finally:
        bridge.close()
