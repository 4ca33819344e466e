"""Mission figures: wall time of the full demo mission and its speed-up over real time.

Run: ``.venv/bin/python benchmarks/bench_mission.py [RUNS]``. Prints the figures
that ``docs/performance.md`` quotes under "Missions and demo".

The mission is the demo's: ``scenarios/lab.route`` planned on the lab network
and run as one tree on the in-process simulator (simulated clock, 20 Hz ticks,
100 Hz state frames through the real wire protocol and the supervisor), with
the trace written, through the front door ``pirate-bt mission`` and planner code
use (:func:`pirate_bt.simulate_mission`), without the live view and the
pictures. Wall time is measured around that call (connecting to the simulator
and the run; planning, a few milliseconds, before it); the speed-up is simulated
mission time over wall time. Median and range over RUNS runs (default 3).
"""

from __future__ import annotations

import argparse
import platform
import statistics
import sys
import tempfile
import time
from pathlib import Path

from report import publish

REPO = Path(__file__).resolve().parent.parent
TARGET_X = 250.0
"""Issue 27's target for the lab mission with its trace (times real time)."""


def one_run(out_dir: Path, trace: bool = True, suffix: str = ".jsonl") -> tuple[float, float, int]:
    """One lab mission through the front door ``pirate-bt mission`` uses: wall, sim s, ticks."""
    import pirate_bt

    plan = pirate_bt.plan_route(REPO / "scenarios" / "lab.route")
    started = time.perf_counter()
    result = pirate_bt.simulate_mission(plan, trace=out_dir / f"trace{suffix}" if trace else None)
    wall = time.perf_counter() - started
    if not result.succeeded:
        sys.exit(f"the mission failed: {result.why}")
    return wall, result.run.sim_time_s, result.run.ticks


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="?", type=int, default=3)
    runs = parser.parse_args().runs
    walls: list[float] = []
    sim_s = 0.0
    ticks = 0
    for _ in range(runs):
        with tempfile.TemporaryDirectory() as tmp:
            wall, sim_s, ticks = one_run(Path(tmp))
        walls.append(wall)
    median = statistics.median(walls)
    print(
        f"machine: {platform.processor() or platform.machine()}, Python {platform.python_version()}"
    )
    print(
        f"lab mission: {sim_s:.0f} s simulated, {ticks} ticks;"
        f" wall {median:.1f} s (range {min(walls):.1f}-{max(walls):.1f} s over {runs} runs)"
    )
    print(
        f"speed-up over real time: {sim_s / median:.0f}x"
        f" (range {sim_s / max(walls):.0f}-{sim_s / min(walls):.0f}x)"
    )
    print(f"wall time per tick: {median / ticks * 1e3:.2f} ms")
    speed = sim_s / median
    publish(
        "mission",
        ["the lab mission, trace written", "now", "target"],
        [
            ["simulated time, ticks at 20 Hz", f"{sim_s:.0f} s, {ticks:,} ticks", ""],
            [
                f"wall time, median of {runs} runs (range)",
                f"{median:.2f} s ({min(walls):.2f}–{max(walls):.2f})",
                "",
            ],
            [
                "speed-up over real time",
                f"**{speed:.0f}x** ({sim_s / max(walls):.0f}–{sim_s / min(walls):.0f}x)",
                f"{TARGET_X:.0f}x (issue 27): {'**met**' if speed >= TARGET_X else 'not met'}",
            ],
            ["wall time per tick", f"{median / ticks * 1e3:.2f} ms", ""],
        ],
        note=f"`scenarios/lab.route` on the lab network through `pirate_bt.simulate_mission`"
        f" (what `pirate-bt mission` runs), in process on the simulator (20 Hz ticks,"
        f" 100 Hz state frames through the wire protocol and the supervisor), its trace"
        f" written; wall time around the call (connecting and the run); {runs} runs.",
    )


if __name__ == "__main__":
    main()
