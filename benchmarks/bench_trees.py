"""Tick time of a 50-node tree from YAML (with the runner) against plain py_trees, and load time.

Run: ``.venv/bin/python benchmarks/bench_trees.py``. Prints the figures written
under "Trees and runner" in docs/performance.md.
"""

from __future__ import annotations

import statistics
import time
from typing import Any

import py_trees
from report import publish

from pirate_bt.clock import SimClock
from pirate_bt.resources import data_dir
from pirate_bt.robot import load_robot
from pirate_bt.runner import Runner
from pirate_bt.treefile import load_tree

TICKS = 2000
RUNS = 5
TARGET_RATIO = 1.25
"""The tree engine's target: a tick of the YAML tree via the runner against bare py_trees."""
GROUPS = 8  # root + guard + parallel + 8 x (timeout + sequence + 4 leaves) = 51 nodes


def _yaml_tree() -> dict[str, Any]:
    groups = []
    for g in range(GROUPS):
        groups.append(
            {
                "type": "timeout",
                "name": f"limit {g}",
                "duration": "1 h",
                "child": {
                    "type": "sequence",
                    "name": f"group {g}",
                    "memory": False,
                    "children": [{"type": "success", "name": f"s{g}-{i}"} for i in range(3)]
                    + [{"type": "running", "name": f"r{g}"}],
                },
            }
        )
    return {
        "root": {
            "type": "eternal_guard",
            "name": "root",
            "conditions": [{"type": "success", "name": "guard"}],
            "child": {"type": "parallel", "name": "all", "policy": "all", "children": groups},
        }
    }


def _plain_tree() -> py_trees.behaviour.Behaviour:
    groups = []
    for g in range(GROUPS):
        leaves = [py_trees.behaviours.Success(f"s{g}-{i}") for i in range(3)]
        leaves.append(py_trees.behaviours.Running(f"r{g}"))
        seq = py_trees.composites.Sequence(f"group {g}", False, leaves)
        groups.append(py_trees.decorators.Timeout(f"limit {g}", seq, 3600.0))
    par = py_trees.composites.Parallel("all", py_trees.common.ParallelPolicy.SuccessOnAll(), groups)
    return py_trees.composites.Sequence("root", False, [py_trees.behaviours.Success("guard"), par])


def _time_plain(root: py_trees.behaviour.Behaviour) -> float:
    tree = py_trees.trees.BehaviourTree(root)
    tree.setup()
    t0 = time.perf_counter()
    for _ in range(TICKS):
        tree.tick()
    return (time.perf_counter() - t0) / TICKS


def _time_runner(clock: SimClock, tree: Any) -> float:
    result = Runner(tree, clock=clock, period_s=0.01, max_time_s=TICKS * 0.01).run()
    return result.mean_tick_s


def main() -> None:
    yaml_best, plain_best = [], []
    for _ in range(RUNS):
        clock = SimClock()
        loaded = load_tree(_yaml_tree(), clock=clock)
        n = sum(1 for _ in loaded.root.iterate())
        yaml_best.append(_time_runner(clock, loaded))
        plain_best.append(_time_plain(_plain_tree()))
    y, p = min(yaml_best), min(plain_best)
    print(f"nodes: {n}")
    print(
        f"tick, YAML tree via Runner: {y * 1e6:8.1f} us"
        f" (median {statistics.median(yaml_best) * 1e6:.1f})"
    )
    print(
        f"tick, plain py_trees:       {p * 1e6:8.1f} us"
        f" (median {statistics.median(plain_best) * 1e6:.1f})"
    )
    print(f"ratio: {y / p:.2f}x (target <= 1.25x)")
    robot = load_robot()
    files = sorted(data_dir("trees").rglob("*.yaml"))
    for path in files:  # warm: imports and first-use caches are not what we measure
        load_tree(path, robot=robot, use_examples=True)
    t0 = time.perf_counter()
    for path in files:
        # As `pirate-bt validate` does: parameters without a default take their example.
        load_tree(path, robot=robot, use_examples=True)
    total = time.perf_counter() - t0
    print(
        f"load+validate {len(files)} shipped trees: {total * 1e3:.1f} ms"
        f" ({total / max(len(files), 1) * 1e3:.2f} ms each)"
    )
    met = "**met**" if y / p <= TARGET_RATIO else "not met"
    publish(
        "trees",
        ["figure", "pirate_bt: YAML tree, `Runner`", "bare py_trees, same structure", "ratio"],
        [
            [
                f"tick of the {n}-node tree, best of {RUNS} runs (median)",
                f"**{y * 1e6:.1f} µs** ({statistics.median(yaml_best) * 1e6:.1f})",
                f"{p * 1e6:.1f} µs ({statistics.median(plain_best) * 1e6:.1f})",
                f"**{y / p:.2f}x** (target ≤ {TARGET_RATIO}x: {met})",
            ],
            [
                f"load + validate the {len(files)} shipped trees",
                f"{total * 1e3:.1f} ms, {total / max(len(files), 1) * 1e3:.2f} ms each",
                "-",
                "-",
            ],
        ],
        note=f"The tree: an eternal guard over a parallel of {GROUPS} timeouts over sequences"
        " of stub leaves, from YAML and ticked by the `Runner` on a simulated clock;"
        " the peer is the same structure built in py_trees (its own `Timeout`, `Success`,"
        f" `Running`) ticked in a bare `tree.tick()` loop; {TICKS} ticks a run. The shipped"
        " trees (the PABs, their `lib/` subtrees, the examples) are loaded against the"
        " default robot as `pirate-bt validate` does, warm.",
    )


if __name__ == "__main__":
    from report import no_arguments

    no_arguments(__doc__)
    main()
