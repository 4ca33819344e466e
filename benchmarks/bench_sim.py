"""Simulator figures: simulated seconds per wall second for a scripted drive through the lab.

Run: ``.venv/bin/python benchmarks/bench_sim.py``. Prints the figures that
``docs/performance.md`` quotes under "Simulator".

The drive is :class:`~pirate_bt.sim.script.ScriptedDrive` through the main path
of ``scenarios/lab.yaml`` (29.6 m, five bends, two tees passed straight, a
reducer, a riser): about 456 s of simulated time with the default robot, so
45 600 physics steps and as many STATE frames at the default 10 ms state period.
Each configuration runs five times; the median and the range are reported (the
machine is shared: the range shows how much other jobs disturbed the runs).

- ``sim + wire``: the scripted drive commands the model directly; every STATE
  frame is still encoded by the simulated bridge and read off the in-process
  ``sim://`` port by a raw reader (no decoding). This is the simulator's own cost.
- ``sim + host link``: the same drive through a host ``RobotLink`` opened on the
  ``sim://`` URL (setpoint frames, acks, heartbeats, every STATE frame decoded by
  the host's session). This is what a test or a tree run pays in process.
"""

from __future__ import annotations

import statistics
import time

import serial
from report import publish

from pirate_bt.clock import SimClock
from pirate_bt.link import open_link
from pirate_bt.robot import load_robot
from pirate_bt.sim import Simulator
from pirate_bt.sim.script import LinkSink, ModelSink, ScriptedDrive

ROBOT = load_robot()
RUNS = 5


class DrainingSink(ModelSink):
    """Commands into the model; waiting advances 10 ms at a time and drains the port."""

    def __init__(self, sim: Simulator) -> None:
        super().__init__(sim)
        self.port = serial.serial_for_url(sim.url, timeout=0)
        self.bytes_read = 0

    def wait(self, seconds: float) -> None:
        clock = self.sim.clock
        end = clock.now() + seconds
        while clock.now() < end - 1e-9:
            clock.advance(min(0.01, end - clock.now()))
            self.bytes_read += len(self.port.read(1 << 16))


def run(with_link: bool) -> tuple[float, float, int]:
    clock = SimClock()
    with Simulator("lab", ROBOT, clock=clock) as sim:
        start = time.perf_counter()
        if with_link:
            link = open_link(sim.url, ROBOT, clock)
            sink: ModelSink | LinkSink = LinkSink(link, clock)
        else:
            sink = DrainingSink(sim)
        drive = ScriptedDrive(sim, sink)
        drive.run_path()
        wall = time.perf_counter() - start
        counters = sim.counters()
        assert counters.stuck_events == 0 and counters.violation_count == 0
        return clock.now(), wall, counters.state_frames_sent


LABELS = {
    "sim + wire": "the scripted drive through the lab network, in process: simulator + wire",
    "sim + host link": "the same drive from host code through `RobotLink` on `sim://`",
}
TARGET_X = 200.0
"""The target, simulated seconds per wall second (issue 15's for the host row)."""


def main() -> None:
    print(f"scripted drive through lab.yaml, state period {ROBOT.bridge.state_period * 1e3:g} ms")
    rows = []
    simulated_s, n_frames = 0.0, 0
    for label, with_link in (("sim + wire", False), ("sim + host link", True)):
        runs = [run(with_link) for _ in range(RUNS)]
        speeds = sorted(simulated / wall for simulated, wall, _ in runs)
        per_step = sorted(wall / frames * 1e6 for _, wall, frames in runs)
        print(
            f"{label:16s} {runs[0][0]:7.1f} s simulated, {runs[0][2]} state frames:"
            f" median {statistics.median(speeds):4.0f}x real time"
            f" ({speeds[0]:.0f}-{speeds[-1]:.0f}x over {RUNS} runs),"
            f" {statistics.median(per_step):5.1f} us per 10 ms step"
            f" ({per_step[0]:.1f}-{per_step[-1]:.1f})"
        )
        simulated_s, n_frames = runs[0][0], runs[0][2]
        speed = statistics.median(speeds)
        rows.append(
            [
                LABELS[label],
                f"**{speed:.0f}x** ({speeds[0]:.0f}–{speeds[-1]:.0f}x)",
                f"{statistics.median(per_step):.1f} µs",
                "**met**" if speed >= TARGET_X else "not met",
            ]
        )
    publish(
        "sim",
        [
            "configuration",
            "simulated s per wall s",
            f"per {ROBOT.bridge.state_period * 1e3:g} ms step",
            f"target ≥ {TARGET_X:.0f}x",
        ],
        rows,
        note=f"Median and range of {RUNS} runs of each; {simulated_s:.0f} s simulated,"
        f" {n_frames:,} STATE frames a run.",
    )


if __name__ == "__main__":
    from report import no_arguments

    no_arguments(__doc__)
    main()
