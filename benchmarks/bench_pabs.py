"""Simulated time, wall time and ticks of each PAB in its matching scenario.

Run: ``.venv/bin/python benchmarks/bench_pabs.py``. Each PAB runs in process (runner
at 20 Hz on a simulated clock, the simulator behind the real link and supervisor)
from the scenario's entry, over 5 seeds with typical sensor noise, without and with
link faults (drop 5 %, corrupt 1 %). Prints the table written under "Primitives
and PABs" in docs/performance.md.
"""

from __future__ import annotations

import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))

from report import publish
from test_pabs import LINK_FAULTS, run_pab

RUNS = [
    ("straight", "straight.yaml", {"distance": "1.5 m"}, "straight"),
    ("bend roll 90°", "bend.yaml", {"roll": "90 deg"}, "bend-right"),
    ("bend roll -90°", "bend.yaml", {"roll": "-90 deg"}, "bend-left"),
    ("bend roll 0°", "bend.yaml", {"roll": "0 deg"}, "bend-up"),
    ("bend roll 180°", "bend.yaml", {"roll": "180 deg"}, "bend-down"),
    ("t-joint left", "t-joint.yaml", {"direction": "left"}, "t-joint"),
    ("t-joint straight", "t-joint.yaml", {"direction": "straight"}, "t-joint"),
]
SEEDS = range(5)


def main() -> None:
    rows = []
    for label, tree, params, scenario in RUNS:
        for faults in (None, LINK_FAULTS):
            sims, walls, ticks = [], [], []
            for seed in SEEDS:
                t0 = time.perf_counter()
                out = run_pab(tree, params, scenario, seed=seed, link_faults=faults)
                walls.append(time.perf_counter() - t0)
                assert out.result.succeeded, (label, seed, out.safe_reason)
                sims.append(out.result.sim_time_s)
                ticks.append(out.result.ticks)
            rows.append(
                [
                    label,
                    scenario,
                    "drop 5 %, corrupt 1 %" if faults else "none",
                    f"{statistics.mean(sims):.1f} s",
                    f"{statistics.mean(walls):.2f} s",
                    f"{statistics.mean(ticks):.0f}",
                ]
            )
            print(" | ".join(rows[-1]), flush=True)
    publish(
        "pabs",
        ["PAB", "scenario", "link faults", "simulated time", "wall time", "ticks"],
        rows,
        note=f"Mean of {len(SEEDS)} seeds with sensor noise; each PAB from its scenario's"
        " entry, the runner at 20 Hz on a simulated clock, the simulator behind the real"
        " link and supervisor.",
    )


if __name__ == "__main__":
    from report import no_arguments

    no_arguments(__doc__)
    main()
