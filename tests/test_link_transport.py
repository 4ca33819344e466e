"""Transports on pyserial URLs (loop://, spy://) and the fault-injection wrapper."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from pirate_bt.clock import SimClock, WallClock
from pirate_bt.errors import InputError, LinkError
from pirate_bt.link import (
    FaultSpec,
    FaultyLink,
    FrameCodec,
    FrameDecoder,
    Heartbeat,
    Transport,
    is_real_port,
    parse_fault_spec,
    split_fault_url,
)
from pirate_bt.link.testing import FdPort, memory_pair
from pirate_bt.robot import load_robot

CODEC = FrameCodec.for_robot(load_robot())


def test_loop_round_trip_and_short_reads() -> None:
    t = Transport.open("loop://", baud=115200)
    try:
        assert t.read_available() == b""
        t.write(b"hello")
        clock = SimClock()
        assert t.read(3, 0.01, clock) == b"hel"
        assert t.read(10, 0.01, clock) == b"lo"  # short read after the timeout
        assert clock.now() == pytest.approx(0.01)
        t.write(b"stale")
        assert t.drain_input() >= 0
        assert t.read_available() == b""
        assert t.port.write_timeout is not None
    finally:
        t.close()
        t.close()


def test_spy_url_over_a_pty_logs_traffic(tmp_path: Path) -> None:
    log = tmp_path / "spy.txt"
    master, slave = os.openpty()
    far = FdPort(master)
    t = Transport.open(f"spy://{os.ttyname(slave)}?file={log}", baud=115200)
    try:
        assert t.real_port is False  # a URL: no DTR reset wait
        t.write(CODEC.encode(Heartbeat(9)))
        clock = WallClock()
        got = b""
        for _ in range(200):
            got += far.read_available()
            if got.endswith(b"\x00"):
                break
            clock.sleep(0.001)
        assert FrameDecoder(CODEC).feed(got) == [Heartbeat(9)]
        far.write(CODEC.encode(Heartbeat(10)))
        assert FrameDecoder(CODEC).feed(t.read(6, 0.5, clock)[:6] + t.read(10, 0.1, clock)) == [
            Heartbeat(10)
        ]
    finally:
        t.close()
        os.close(slave)
        far.close()
    assert "TX" in log.read_text() or log.stat().st_size > 0


def test_open_refuses_bad_url() -> None:
    with pytest.raises(LinkError):
        Transport.open("nonsense-scheme://x", baud=115200)
    assert is_real_port("/dev/ttyACM0") and not is_real_port("loop://")


def test_parse_fault_spec() -> None:
    spec = parse_fault_spec("drop=0.1,corrupt=0.02,dup=0.02,delay=5ms,reorder=0.01,seed=3")
    assert spec == FaultSpec(0.1, 0.02, 0.02, 0.005, 0.0, 0.01, 3)
    assert spec.active and not parse_fault_spec("").active


@pytest.mark.parametrize(
    "text",
    [
        "drop=2",
        "drop=x",
        "lose=0.1",
        "drop",
        "delay=5",
        "delay=5 kg",
        "drop=0.1,drop=0.2",
        "seed=1.5",
        "direction=up",
    ],
)
def test_bad_fault_specs(text: str) -> None:
    with pytest.raises(InputError):
        parse_fault_spec(text)


def test_fault_url_options() -> None:
    url, spec = split_fault_url("loop://?logging=debug&faults=drop=0.1,dup=0.2&fault_seed=4")
    assert url == "loop://?logging=debug"
    assert spec == FaultSpec(drop=0.1, dup=0.2, seed=4)
    assert split_fault_url("/dev/ttyACM0") == ("/dev/ttyACM0", None)


def _run(spec: FaultSpec) -> tuple[bytes, dict[str, dict[str, int]]]:
    clock = SimClock()
    host, far = memory_pair()
    link = FaultyLink(host, spec, clock)
    for i in range(300):
        link.write(CODEC.encode(Heartbeat(i)))
        clock.sleep(0.001)
    link.write(b"")
    return far.read_available(), link.counts


def test_faults_are_seeded_and_counted() -> None:
    spec = parse_fault_spec("drop=0.1,corrupt=0.05,dup=0.05,reorder=0.05,seed=9")
    a, counts = _run(spec)
    b, _ = _run(spec)
    assert a == b  # same seed, same faults
    tx = counts["tx"]
    assert tx["frames"] == 300 and tx["dropped"] > 10 and tx["corrupted"] > 3
    assert tx["duplicated"] > 3 and tx["reordered"] > 3
    out = FrameDecoder(CODEC).feed(a)
    seqs = [m.seq for m in out if isinstance(m, Heartbeat)]
    assert seqs != sorted(seqs)  # reordered
    assert len(seqs) != len(set(seqs))  # duplicated


def test_delay_waits_on_the_injected_clock() -> None:
    clock = SimClock()
    host, far = memory_pair()
    link = FaultyLink(host, parse_fault_spec("delay=5ms"), clock)
    link.write(CODEC.encode(Heartbeat(1)))
    assert far.read_available() == b""
    clock.sleep(0.004)
    link.read_available()
    assert far.read_available() == b""
    clock.sleep(0.001)
    link.read_available()
    assert FrameDecoder(CODEC).feed(far.read_available()) == [Heartbeat(1)]


def test_socket_url() -> None:
    import socket

    server = socket.create_server(("127.0.0.1", 0))
    port = server.getsockname()[1]
    t = Transport.open(f"socket://127.0.0.1:{port}", baud=115200)
    conn, _ = server.accept()
    try:
        t.write(CODEC.encode(Heartbeat(5)))
        conn.sendall(conn.recv(100))  # echo
        got = t.read(len(CODEC.encode(Heartbeat(5))), 1.0, WallClock())
        assert FrameDecoder(CODEC).feed(got) == [Heartbeat(5)]
    finally:
        t.close()
        conn.close()
        server.close()
