"""The simulated bridge (the Python one behind ``pirate-bt sim``) against the same tables
of damaged frames as the firmware (tests/test_wire24_firmware_tables.py): each damaged
frame counted as the page says, none answered, none acted on."""

from __future__ import annotations

import struct

import pytest
from conformance.bridge import InProcessSimBridge
from test_firmware_core import (
    ACK,
    APPLIED,
    COUNTERS_REQUEST,
    ESTOP_RESET,
    HELLO,
    SETPOINT,
    STATE,
    Frame,
    frame,
    parse,
)
from test_wire24_firmware_tables import BRIDGE_HEARTBEAT, GOOD, TABLES, classify

from pirate_bt.robot import load_robot

ROBOT = load_robot()


def answers(bridge: InProcessSimBridge, data: bytes, seconds: float = 0.002) -> list[Frame]:
    bridge.write(data)
    return [f for f in parse(bridge.read(seconds)) if f.kind not in (STATE, BRIDGE_HEARTBEAT)]


def counters(bridge: InProcessSimBridge, seq: int) -> tuple[int, int, int]:
    (reply,) = answers(bridge, frame(COUNTERS_REQUEST, seq))
    return struct.unpack("<3I", reply.payload[:12])  # type: ignore[return-value]


@pytest.mark.parametrize("table", sorted(TABLES))
def test_the_simulated_bridge_counts_and_drops_every_damaged_frame(table: str) -> None:
    bridge = InProcessSimBridge(ROBOT)
    bridge.advance(0.025)
    hello = frame(HELLO, 1, payload=struct.pack("<IB", ROBOT.layout_digest(), 1))
    assert [f.kind for f in answers(bridge, hello)] == [0x81]
    assert answers(bridge, frame(ESTOP_RESET, 2)) == [Frame(ACK, 2, 0, bytes([ESTOP_RESET, 0]))]
    rx0, crc0, framing0 = counters(bridge, 0x101)
    want_crc = want_framing = 0
    for damaged in TABLES[table]():
        wire = damaged + b"\x00"
        crc, framing, intact = classify(wire)
        assert intact == 0
        want_crc += crc
        want_framing += framing
        assert answers(bridge, wire, 0.0005) == [], damaged.hex()
    rx, crc, framing = counters(bridge, 0x102)
    assert (rx - rx0, crc - crc0, framing - framing0) == (1, want_crc, want_framing)
    assert answers(bridge, GOOD) == [Frame(ACK, 3, 0, bytes([SETPOINT, APPLIED]))]
