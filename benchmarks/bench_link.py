"""Link figures: codec speed, frames/s and request RTT over a pty, and the 10 ms slot budget.

Run with ``.venv/bin/python benchmarks/bench_link.py``; it prints a Markdown table
(the one in ``docs/performance.md``, section Link). Wall-clock figures depend on
the machine; nothing here is a timed assertion in the test suite.
"""

from __future__ import annotations

import os
import platform
import statistics
import sys
import threading
import time
import timeit

from report import publish

from pirate_bt.clock import WallClock
from pirate_bt.link import (
    BridgeFlags,
    BulkSetpoints,
    FrameCodec,
    FrameDecoder,
    SessionConfig,
    State,
    Transport,
    WireLayout,
    open_link,
)
from pirate_bt.link.codec import frame_time_s
from pirate_bt.link.testing import FdPort
from pirate_bt.robot import ControlMode, load_robot
from pirate_bt.sim.bridge_port import BridgeOnPort, bridge_for

CODEC_TARGET_US = 5.0
"""The target for a STATE frame's encode and for its decode (docs/performance.md, Link)."""
SHARE_TARGET = 0.70
"""The largest share of a state period a frame may take on the line."""


def per_call_us(fn: object, number: int = 20_000, repeat: int = 15) -> float:
    """Median over ``repeat`` runs of ``number`` calls, in microseconds per call.

    The median, not the best run, so a figure is what a call usually costs on a
    machine with other jobs running.
    """
    runs = timeit.repeat(fn, number=number, repeat=repeat)  # type: ignore[arg-type]
    return statistics.median(runs) / number * 1e6


def main() -> None:
    robot = load_robot()
    layout = WireLayout.from_robot(robot)
    codec = FrameCodec(layout)
    n = layout.n_channels
    state = State(
        1234,
        BridgeFlags.NONE,
        77,
        (1 << n) - 1,
        (1,) * layout.n_boards,
        tuple((i * 1237) % 4000 - 2000 for i in range(n)),
    )
    bulk = BulkSetpoints(
        55,
        tuple([ControlMode.TORQUE, ControlMode.VELOCITY] * (layout.n_motors // 2)),
        tuple(range(-8, layout.n_motors - 8)),
    )
    state_wire, bulk_wire = codec.encode(state), codec.encode(bulk)
    decoder = FrameDecoder(codec)
    enc_state = per_call_us(lambda: codec.encode(state))
    dec_state = per_call_us(lambda: decoder.feed(state_wire))
    enc_bulk = per_call_us(lambda: codec.encode(bulk))
    dec_bulk = per_call_us(lambda: decoder.feed(bulk_wire))
    baud, slot = robot.bridge.baud, robot.bridge.state_period
    s_bytes = layout.wire_bytes(layout.state_payload_bytes)
    b_bytes = layout.wire_bytes(layout.bulk_payload_bytes)

    # frames per second through a pty (no baud limit on a pty: this is host CPU + OS)
    master, slave = os.openpty()
    far = FdPort(master)
    host = Transport.open(os.ttyname(slave), baud=robot.bridge.baud)
    count = 20_000
    blob = state_wire * 100

    def writer() -> None:
        for _ in range(count // 100):
            far.write(blob)

    got = 0
    decoder = FrameDecoder(codec)
    t0 = time.perf_counter()
    thread = threading.Thread(target=writer)
    thread.start()
    while got < count and time.perf_counter() - t0 < 30:
        data = host.read_available()
        if data:
            got += sum(1 for m in decoder.feed(data) if isinstance(m, State))
    elapsed = time.perf_counter() - t0
    thread.join()
    host.close()
    far.close()
    os.close(slave)
    frames_s = got / elapsed

    # request/response RTT over a pty with the reference bridge in a thread
    master, slave = os.openpty()
    clock = WallClock()
    bridge = BridgeOnPort(FdPort(master), bridge_for(robot, start_s=clock.now()))
    bridge.start(clock, period_s=0.0001)
    cfg = SessionConfig.from_robot(robot, poll_step_s=0.0001)
    link = open_link(os.ttyname(slave), robot, clock, config=cfg, reset_wait_s=0, threaded=False)
    rtts = []
    for i in range(1000):
        t = time.perf_counter()
        link.session.wait(link.session.send_setpoint(22, 1, ControlMode.VELOCITY, i % 100))
        rtts.append(time.perf_counter() - t)
    link.close()
    bridge.stop()
    os.close(master)
    os.close(slave)
    rtts.sort()
    p99 = rtts[int(0.99 * len(rtts)) - 1]

    state_share = frame_time_s(s_bytes, baud) / slot
    bulk_share = frame_time_s(b_bytes, baud) / slot
    cpu = enc_bulk + dec_state
    print(f"Python {sys.version.split()[0]} on {platform.machine()}, {os.cpu_count()} cores")

    def met(ok: bool) -> str:
        return "**met**" if ok else "not met"

    def pct(share: float, digits: int = 1) -> str:
        return f"{share * 100:.{digits}f} %"

    publish(
        "link",
        ["figure", "now", "target"],
        [
            [
                f"state frame encode / decode ({s_bytes} B)",
                f"{enc_state:.1f} µs / {dec_state:.1f} µs",
                f"≤ {CODEC_TARGET_US:g} µs: {met(max(enc_state, dec_state) <= CODEC_TARGET_US)}",
            ],
            [
                f"bulk setpoint encode / decode ({b_bytes} B)",
                f"{enc_bulk:.1f} µs / {dec_bulk:.1f} µs",
                "",
            ],
            [
                "state frames/s received and decoded over a pty",
                f"{round(frames_s, -3):,.0f}".replace(",", " "),
                "",
            ],
            [
                "SETPOINT → ACK round trip over a pty, median / p99",
                f"{statistics.median(rtts) * 1e3:.2f} ms / {p99 * 1e3:.2f} ms",
                "",
            ],
            [
                f"one {1 / slot:.0f} Hz cycle at {baud} baud: state in / bulk out",
                f"{pct(state_share)} / {pct(bulk_share)} of the {slot * 1e3:.0f} ms slot",
                f"≤ {pct(SHARE_TARGET, 0)}: {met(max(state_share, bulk_share) <= SHARE_TARGET)}",
            ],
            [
                "host CPU per cycle (encode bulk + decode state)",
                f"{cpu:.1f} µs, {pct(cpu / (slot * 1e6), 2)} of the slot",
                "",
            ],
        ],
        note="Codec figures: the median of 15 runs of 20 000 calls; frames/s: 20 000 STATE"
        " frames written to a pty by a thread; round trip: 1000 SETPOINTs to the reference"
        " bridge on a pty (median and 99th percentile); line shares: arithmetic on the frame"
        " sizes ([protocol.md](protocol.md)).",
    )


if __name__ == "__main__":
    from report import no_arguments

    no_arguments(__doc__)
    main()
