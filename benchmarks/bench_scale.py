"""Scaling figures: what one tick costs as the tree grows, and missions at scale.

Run: ``.venv/bin/python benchmarks/bench_scale.py [--quick] [--only PART ...]``.
Prints the figures that ``docs/performance.md`` quotes under "Scale".

Parts:

``ticks``
    A mission-shaped tree: a root sequence (with memory) of K copies of the same
    31-node PAB-shaped subtree (a sequence of five steps, each a selector of a
    "try" sequence -- a check, two actions -- and a recovery leaf), only the first
    copy active (its first action runs for ever). K = 1, 10, 100 gives 32, 311 and
    3,101 nodes with the same active path. Per-tick wall time on the
    :class:`pirate_bt.runner.Runner` with a simulated clock, without and with a
    trace (the default writer process, to a temporary ``.jsonl``), and of
    py_trees' ``root.tick()`` alone. Median of five alternating runs.
``sparse``
    The trace overhead on the sparse 50-node tree of ``bench_trace.py`` (a root
    sequence of 7 PAB-like steps, one active), ticked by the runner: extra time
    per tick with the trace, in % of the untraced tick (median of 15 ABBA pairs).
``mission``
    ``pirate-bt mission scenarios/lab.route --sim lab --quiet`` in process (no
    outputs): simulated seconds over wall seconds, median of three.
``long``
    A 220-PAB route (``scenarios/lab-long.route``: the lab main's inspection twelve
    times over, on ``scenarios/lab-long.yaml``): the time and the peak memory
    (``tracemalloc``) to plan it and load, check and build its tree, the node count,
    and the per-tick cost of the first 200 s of its mission against the lab
    mission's (both start with the same PABs).
"""

from __future__ import annotations

import argparse
import gc
import platform
import resource
import statistics
import sys
import tempfile
import time
import tracemalloc
from collections.abc import Callable
from pathlib import Path
from typing import Any

import py_trees

from pirate_bt.clock import SimClock
from pirate_bt.runner import Runner
from pirate_bt.trace import attach_trace

REPO = Path(__file__).resolve().parent.parent
WARM_UP = 100
FOREVER = 10**12
"""Ticks of the one action that keeps the first PAB running."""
sys.path.insert(0, str(REPO / "benchmarks"))
from bench_trace import Step  # noqa: E402 - a leaf that runs N ticks, with progress
from report import publish  # noqa: E402


def pab_subtree(k: int) -> py_trees.behaviour.Behaviour:
    """31 nodes: sequence of 5 x selector(sequence(check, act, act), recover)."""
    steps = []
    for s in range(5):
        attempt = py_trees.composites.Sequence(
            f"try {k}.{s}",
            memory=True,
            children=[
                py_trees.behaviours.Success(f"check {k}.{s}"),
                Step(f"act {k}.{s}", FOREVER if (k, s) == (0, 0) else 3),
                Step(f"confirm {k}.{s}", 2),
            ],
        )
        steps.append(
            py_trees.composites.Selector(
                f"step {k}.{s}",
                memory=False,
                children=[attempt, py_trees.behaviours.Failure(f"recover {k}.{s}")],
            )
        )
    return py_trees.composites.Sequence(f"pab {k}", memory=True, children=steps)


def mission_tree(copies: int) -> py_trees.behaviour.Behaviour:
    children = [pab_subtree(k) for k in range(copies)]
    return py_trees.composites.Sequence("mission", memory=True, children=children)


def count_nodes(root: py_trees.behaviour.Behaviour) -> int:
    return sum(1 for _ in root.iterate())


def runner_us_per_tick(copies: int, ticks: int, trace_dir: Path | None) -> float:
    clock = SimClock()
    runner = Runner(mission_tree(copies), clock=clock, period_s=0.01, max_time_s=ticks * 0.01)
    if trace_dir is not None:
        attach_trace(runner, trace_dir / f"scale-{copies}.jsonl")
    # Steady state: from the end of tick 100 to the end of the last tick, hooks (the
    # trace) included; set-up, the trace's header and closing are one-off costs.
    marks: dict[int, float] = {}

    def mark(info: Any) -> None:
        if info.tick == WARM_UP or info.tick == ticks:
            marks[info.tick] = time.perf_counter()

    runner.add_post_tick(mark)
    gc.collect()
    runner.run()
    return (marks[ticks] - marks[WARM_UP]) / (ticks - WARM_UP) * 1e6


def plain_us_per_tick(copies: int, ticks: int) -> float:
    root = mission_tree(copies)
    root.setup_with_descendants()
    for _ in root.tick():  # the first tick initialises every step on the way
        pass
    started = time.perf_counter()
    for _ in range(ticks):
        for _ in root.tick():
            pass
    return (time.perf_counter() - started) / ticks * 1e6


def median_of(runs: int, fn: Callable[[], float]) -> tuple[float, float, float]:
    values = [fn() for _ in range(runs)]
    return statistics.median(values), min(values), max(values)


def part_ticks(quick: bool) -> None:
    ticks = 500 if quick else 3000
    runs = 3 if quick else 5
    print(f"\n# per-tick cost against tree size ({ticks} ticks a run, median of {runs})")
    print("| nodes | Runner, µs/tick | Runner + trace, µs/tick | py_trees root.tick(), µs/tick |")
    print("|---|---|---|---|")
    table: dict[int, tuple[float, float, float]] = {}
    for copies in (1, 10, 100):
        nodes = count_nodes(mission_tree(copies))
        plain_r: list[float] = []
        traced_r: list[float] = []
        bare_r: list[float] = []
        with tempfile.TemporaryDirectory() as tmp:
            for _ in range(runs):
                plain_r.append(runner_us_per_tick(copies, ticks, None))
                traced_r.append(runner_us_per_tick(copies, ticks, Path(tmp)))
                bare_r.append(plain_us_per_tick(copies, ticks))
        row = (statistics.median(plain_r), statistics.median(traced_r), statistics.median(bare_r))
        table[nodes] = row
        print(f"| {nodes:,} | {row[0]:.1f} | {row[1]:.1f} | {row[2]:.1f} |")
    small, large = min(table), max(table)
    print(
        f"ratio {large:,} / {small} nodes: runner {table[large][0] / table[small][0]:.2f}x,"
        f" runner + trace {table[large][1] / table[small][1]:.2f}x (target <= 1.3x)"
    )
    ratio = table[large][1] / table[small][1]
    publish(
        "scale-ticks",
        ["nodes", "Runner", "Runner + trace", "py_trees `root.tick()` alone (peer)"],
        [
            *(
                [f"{nodes:,}", f"{r[0]:.1f} µs", f"{r[1]:.1f} µs", f"{r[2]:.1f} µs"]
                for nodes, r in sorted(table.items())
            ),
            [
                f"{large:,} / {small}",
                f"{table[large][0] / table[small][0]:.2f}x",
                f"**{ratio:.2f}x** (target ≤ 1.3x: {'**met**' if ratio <= 1.3 else 'not met'})",
                f"{table[large][2] / table[small][2]:.2f}x",
            ],
        ],
        note=f"Per tick, steady state (ticks {WARM_UP} to {ticks}, hooks included), median of"
        f" {runs} runs: a root sequence of K copies of a 31-node PAB-shaped subtree, only the"
        " first active, on the `Runner` with a simulated clock; the trace is the default"
        " writer process; the peer is py_trees' own `root.tick()` on the same tree, bare.",
    )


def part_sparse(quick: bool) -> None:
    import bench_trace

    pairs = 5 if quick else 15
    ticks = 1000 if quick else 5000
    plain: list[float] = []
    traced: list[float] = []
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(pairs):
            order = (False, True) if i % 2 == 0 else (True, False)
            for on in order:
                path = Path(tmp) / f"sparse-{i}.jsonl" if on else None
                value = bench_trace.time_runner_ticks(ticks, path, "sparse")
                (traced if on else plain).append(value)
    extra = [(t - p) / p * 100 for p, t in zip(plain, traced, strict=True)]
    print(f"\n# trace overhead on the sparse 50-node tree ({pairs} ABBA pairs, {ticks} ticks)")
    print(
        f"untraced {statistics.median(plain) * 1e6:.1f} µs/tick, traced"
        f" {statistics.median(traced) * 1e6:.1f} µs/tick: +{statistics.median(extra):.1f} %"
        f" (range {min(extra):+.1f} to {max(extra):+.1f} %; target <= 15 %)"
    )


def run_route(route_path: Path, max_time_s: float | None = None) -> tuple[Any, int]:
    """A route's mission on the in-process simulator, no outputs: (the result, PABs)."""
    from pirate_bt import simulate_mission

    result = simulate_mission(route_path, max_time=max_time_s)
    return result, len(result.plan.pabs)


def lab_mission_once(route_path: Path) -> tuple[float, float, int]:
    """The whole mission: wall seconds (the runner's), simulated seconds, ticks."""
    result, _ = run_route(route_path)
    if not result.succeeded:
        raise SystemExit(f"the mission failed: {result.reason}")
    return result.run.wall_time_s, result.run.sim_time_s, result.run.ticks


def part_mission(quick: bool) -> None:
    runs = 1 if quick else 3
    walls: list[float] = []
    sim_s = 0.0
    ticks = 0
    for _ in range(runs):
        wall, sim_s, ticks = lab_mission_once(REPO / "scenarios" / "lab.route")
        walls.append(wall)
    median = statistics.median(walls)
    print(f"\n# the lab mission end to end (no outputs, median of {runs})")
    print(
        f"{sim_s:.0f} s simulated, {ticks} ticks, wall {median:.2f} s"
        f" (range {min(walls):.2f}-{max(walls):.2f}): {sim_s / median:.0f}x real time"
        f" (target >= 100x); {median / ticks * 1e6:.0f} µs per tick"
    )


def build_route_tree(route_path: Path) -> tuple[int, Any]:
    """Plan a route and load, check and build its mission tree, as ``run_mission`` does."""
    from pirate_bt.clock import SimClock as Clock
    from pirate_bt.robot.loader import load_robot
    from pirate_bt.task.planner import load_network_for, plan_route
    from pirate_bt.task.route import load_route
    from pirate_bt.task.tree import mission_tree_spec
    from pirate_bt.treefile import load_tree

    robot = load_robot()
    route = load_route(route_path)
    plan = plan_route(route, load_network_for(route, None), robot)
    spec = mission_tree_spec(plan, None, robot.motion.nominal_speed)
    loaded = load_tree(spec, robot=robot, clock=Clock(), supervisor=None)
    return len(plan.pabs), loaded.root


def mission_window(route_path: Path, seconds: float) -> tuple[float, int, int]:
    """The first ``seconds`` of a route's mission: wall seconds, ticks, PABs.

    The runner's wall time: every tick with its hooks (supervisor, simulator, link,
    localiser); not the loading of the tree, which part_long times on its own.
    """
    result, pabs = run_route(route_path, max_time_s=seconds)
    return result.run.wall_time_s, result.run.ticks, pabs


def part_long(quick: bool) -> None:
    route = REPO / "scenarios" / "lab-long.route"
    runs = 1 if quick else 3
    times: list[float] = []
    peaks: list[float] = []
    pabs = nodes = 0
    build_route_tree(REPO / "scenarios" / "lab.route")  # imports and caches, once
    rss_before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e3
    for _ in range(runs):
        gc.collect()
        started = time.perf_counter()
        pabs, root = build_route_tree(route)
        times.append(time.perf_counter() - started)
        nodes = count_nodes(root)
        del root
    rss_after = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e3
    # Memory apart: tracemalloc slows allocation several times over.
    gc.collect()
    tracemalloc.start()
    build_route_tree(route)
    peaks.append(tracemalloc.get_traced_memory()[1] / 1e6)
    tracemalloc.stop()
    print("\n# a 220-PAB route: plan, load, check and build its tree")
    print(
        f"{route.name}: {pabs} PABs, {nodes:,} nodes; {statistics.median(times):.2f} s"
        f" (range {min(times):.2f}-{max(times):.2f}); peak {max(peaks):.0f} MB allocated"
        f" (tracemalloc), process peak {rss_after:.0f} MB ({rss_after - rss_before:+.0f} MB"
        " for the build) (targets < 2 s, < 200 MB)"
    )
    window = 200.0
    print(f"per-tick cost over the first {window:.0f} s of each mission (same PABs run):")
    for path in (REPO / "scenarios" / "lab.route", route):
        wall, ticks, count = mission_window(path, window)
        print(f"  {path.name} ({count} PABs): {wall / ticks * 1e6:.0f} µs per tick")


PARTS = {"ticks": part_ticks, "sparse": part_sparse, "mission": part_mission, "long": part_long}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer and shorter runs")
    parser.add_argument("--only", nargs="+", choices=sorted(PARTS), help="parts to run")
    args = parser.parse_args()
    print(f"machine: {platform.machine()}, Python {platform.python_version()}")
    for name in args.only or list(PARTS):
        PARTS[name](args.quick)


if __name__ == "__main__":
    main()
