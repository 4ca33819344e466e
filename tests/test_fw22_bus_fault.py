"""Probe 22: a bus on which no board answers a whole poll cycle, on both bridges.

docs/protocol.md, bridge flags: bit 2 ``BUS_FAULT`` is set while "the last whole RS485
poll cycle failed". The firmware bridge sets it (``poller.c``, ``finish_cycle``); the
simulated bridge, the reference that claims to follow the page to the letter, never did:
with every board rebooting (``board_reset`` on each, or the one board of a one-board
robot) its ``STATE`` frames kept the flag clear, so a host on the simulator saw only
stale readings (*stale data*, exit 1) where on the robot its supervisor names the bus
(*the bridge reports BUS_FAULT ...*, a hardware error, exit 3). Both bridges are driven
by the same bytes here (the conformance suite's in-process ``sim`` and the firmware's
own C, ``firmware-host``); what is checked is the flag on the wire.
"""

from __future__ import annotations

import struct
from collections.abc import Iterator
from pathlib import Path

import pytest
from cleanroom_peer import (
    APPLIED,
    BRIDGE_HEARTBEAT,
    ESTOP_RESET,
    F_BUS_FAULT,
    HEARTBEAT,
    HELLO,
    HELLO_REPLY,
    NOT_READY,
    STATE,
    Decoder,
    Frame,
    frame,
    layout_of,
)
from conformance.bridge import InProcessSimBridge

from pirate_bt.robot import load_robot

ROBOT = load_robot()
LAYOUT = layout_of(ROBOT)
BOARDS = sorted(ROBOT.board_ids())
AWAY_S = 0.4  # every board silent this long


@pytest.fixture(scope="module")
def library(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The bridge firmware's C built for this machine, once for the module."""
    from firmware_host import build_host_library

    try:
        return build_host_library(tmp_path_factory.mktemp("fw22-bus"))
    except RuntimeError as exc:
        if "no host C compiler" in str(exc):
            pytest.skip(f"{exc}: the firmware cannot be built for the host")
        raise


@pytest.fixture(params=["sim", "firmware-host"])
def bridge(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator:
    if request.param == "sim":
        under_test = InProcessSimBridge(ROBOT)
    else:
        from firmware_host import FirmwareHostBridge

        library = request.getfixturevalue("library")
        under_test = FirmwareHostBridge(ROBOT, library, tmp_path)
    try:
        yield under_test
    finally:
        under_test.close()


class Host:
    """Writes frames, lets time pass, keeps the bridge's STATE flags and its answers."""

    def __init__(self, bridge: object) -> None:
        self.bridge = bridge
        self.decoder = Decoder()
        self.seq = 0

    def step(self, kind: int, dt: float = 0.02, payload: bytes = b"") -> list[Frame]:
        self.seq += 1
        self.bridge.write(frame(kind, self.seq, payload))  # type: ignore[attr-defined]
        self.frames = [
            f
            for f in self.decoder.feed(self.bridge.read(dt))  # type: ignore[attr-defined]
            if isinstance(f, Frame)
        ]
        return [f for f in self.frames if f.kind not in (STATE, BRIDGE_HEARTBEAT)]

    def flags(self) -> list[int]:
        return [f.arg for f in self.frames if f.kind == STATE]


def test_a_bus_where_no_board_answers_sets_bus_fault_and_it_clears_when_they_answer(
    bridge: object,
) -> None:
    host = Host(bridge)
    hello = struct.pack("<IB", LAYOUT.digest, 2)
    assert [f.kind for f in host.step(HELLO, payload=hello)] == [HELLO_REPLY]
    assert host.step(ESTOP_RESET)[0].payload == bytes([ESTOP_RESET, APPLIED])
    assert not any(flags & F_BUS_FAULT for flags in host.flags())
    for board in BOARDS:
        bridge.disconnect_board(board, AWAY_S)  # type: ignore[attr-defined]
    seen: list[int] = []
    for _ in range(10):  # 0.2 s with every board silent: at least one whole cycle
        host.step(HEARTBEAT)
        seen += host.flags()
    assert seen and seen[-1] & F_BUS_FAULT, f"STATE flags while no board answers: {seen}"
    # the latch cannot be released while the bus is down (it is not latched: the host
    # latches it here to see the refusal)
    host.step(0x05)  # ESTOP
    refused = host.step(ESTOP_RESET)
    assert refused and refused[0].payload == bytes([ESTOP_RESET, NOT_READY])
    for _ in range(25):  # the boards answer again after AWAY_S
        host.step(HEARTBEAT)
    assert not host.flags()[-1] & F_BUS_FAULT, host.flags()


def test_a_simulated_run_whose_boards_all_reboot_ends_on_the_bus_as_on_the_robot() -> None:
    import pirate_bt

    faults = ",".join(f"board_reset:{board}@1s+1s" for board in BOARDS)
    result = pirate_bt.simulate_tree(
        "straight", params={"distance": "0.3 m"}, network="straight", faults=faults
    )
    assert not result.succeeded
    assert result.exit_code == 3, result.why  # a hardware error, not stale data (exit 1)
    assert result.why.startswith("bus_fault: the bridge reports BUS_FAULT"), result.why
