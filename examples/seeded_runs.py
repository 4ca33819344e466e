"""Twenty seeded runs of a short tree over a lossy link, and the success rate.

Run from the repository root: ``python examples/seeded_runs.py``.

Each seed drives the simulator and the link faults, so a run is repeatable: run
one seed again to see the same failure. For thousands of runs in parallel
processes (or on a Dask cluster), with a report and Wilson intervals, use
``pirate_bt.run_campaign`` (docs/campaigns.md); this loop is the same idea in one
process.
"""

import pirate_bt
from pirate_bt.campaign.stats import wilson_interval

SEEDS = range(20)
failures = []
for seed in SEEDS:
    result = pirate_bt.simulate_tree(
        "straight",
        params={"distance": "0.2 m"},
        seed=seed,
        faults="drop=0.3,corrupt=0.1",  # 30 % of frames lost, 10 % corrupted
    )
    if not result.succeeded:
        failures.append((seed, result))

successes = len(SEEDS) - len(failures)
low, high = wilson_interval(successes, len(SEEDS))  # 95 %, as campaign reports give it
print(
    f"{successes}/{len(SEEDS)} runs succeeded ({successes / len(SEEDS):.0%};"
    f" 95 % interval {low:.0%} to {high:.0%})"
)
for seed, result in failures:
    print(f"  seed {seed}: {result.why}")
    print(f"    at {result.failing_node}; {result.counters.retries} link retries")
