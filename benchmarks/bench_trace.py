"""Trace figures: overhead per tick for the 50-node tree, and trace size per hour.

Run: ``.venv/bin/python benchmarks/bench_trace.py``. Prints the figures that
``docs/performance.md`` quotes under "Trace".

Overhead, three trees, each ticked with and without a
:class:`~pirate_bt.trace.TraceRecorder` (default options: the writer process);
every tick of both also makes that tick's extras as a run does, traced or not
(:class:`RunSnapshots`: the reference robot's state, 28 channels, built by its
``StateBuilder`` from raw values, a fresh link health, one command verdict), and
the traced one records them.
Runs alternate (off, on, off, on ...) so machine load hits both alike; the
figure is the extra time per tick, in µs and in % of the untraced tick, median
over the runs with the range.

- **The 50-node tree** of the target: the tree of the tree-engine figure
  (``bench_trees.py``: 51 nodes from YAML, an eternal guard over a parallel of
  8 timeouts over sequences of stub leaves), ticked by the
  :class:`pirate_bt.runner.Runner` as ``pirate-bt run`` ticks it.
- **A sparse 50-node tree** (a root sequence of 7 PAB-like steps, each a guard
  over a selector/sequence of do-nothing leaves, only one step active), ticked by
  ``tree.tick()`` and by the runner. Its tick is about 40 µs, a fifth of the one
  above, so the same trace cost is a much larger share of it: the harsh case.
- **Whole simulated PAB runs** (runner, supervisor, link, in-process simulator),
  traced the way ``pirate-bt run --trace`` traces them.

Size per hour: a simulated PAB run at the default 10 ms tick (= the 10 ms state
period of the bridge) is written for 60 s of simulated time and scaled to an
hour. Assumptions, stated because they drive the figure: the robot is always
doing one step; the joints and clamp forces of the moving half change every
tick (a sensor reading moves by at least one raw count per 10 ms while a joint
bends), wheel speeds and the currents of the running motors are noisy and
change every tick, and everything else (the idle half, the IMU at rest,
rotation when not rotating) keeps its value, since readings are quantised to
raw counts. Statuses change only at step boundaries; feedback messages change
when a step reports progress (once per 100 ms here).
"""

from __future__ import annotations

import itertools
import statistics
import tempfile
import time
from pathlib import Path
from typing import Any

import py_trees
from trace_inputs import (  # noqa: F401 (re-exported: bench_btcpp, bench_scale)
    STEPS,
    TICK_S,
    RunSnapshots,
    Step,
    extras_up_front,
    fifty_node_tree,
    record_pab_ticks,
    robot_state,
)

from pirate_bt.clock import SimClock
from pirate_bt.runner import Runner
from pirate_bt.trace import TickExtras, TraceRecorder


def time_ticks(
    tree: py_trees.trees.BehaviourTree,
    ticks: int,
    recorder: TraceRecorder | None,
    snapshots: bool = True,
) -> float:
    """Seconds per tick of ``tree.tick()``, recording each tick when ``recorder`` is given.

    With ``snapshots`` each tick's extras are made before its tick, traced or not, as a
    run makes them (:class:`RunSnapshots`); without, a recorder takes extras made up
    front and an untraced run makes none (the tree's tick alone, for bench_btcpp).
    """
    clock = SimClock()
    made = RunSnapshots(ticks) if snapshots else None
    extras = extras_up_front(ticks) if made is None and recorder is not None else []
    start = time.perf_counter()
    for n in range(1, ticks + 1):
        clock.advance(TICK_S)
        tick_extras = made.make(n) if made is not None else None
        tree.tick()
        if recorder is not None:
            recorder.record_tick(
                tick_extras if tick_extras is not None else extras[n - 1], time_s=clock.now()
            )
    return (time.perf_counter() - start) / ticks


def issue6_tree(clock: SimClock) -> Any:
    """The 50-node tree of the tree-engine figure (``bench_trees.py``), loaded from YAML."""
    from bench_trees import _yaml_tree

    from pirate_bt.treefile import load_tree

    return load_tree(_yaml_tree(), clock=clock)


def time_runner_ticks(
    ticks: int, traced: Path | None, tree_kind: str = "sparse", snapshots: bool = True
) -> float:
    """Wall seconds per tick of a 50-node tree run by the Runner, optionally traced.

    ``snapshots`` as for :func:`time_ticks`: made in a pre-tick hook, traced or not.
    """
    clock = SimClock()
    if tree_kind == "issue6":
        tree: Any = issue6_tree(clock)
    else:
        tree = fifty_node_tree(step_ticks=10 * ticks)  # never finishes inside the run
    runner = Runner(tree, clock=clock, period_s=TICK_S, max_time_s=ticks * TICK_S)
    made = RunSnapshots(ticks) if snapshots else None
    extras = extras_up_front(ticks) if made is None and traced is not None else []
    current: list[TickExtras] = []
    if made is not None:
        source, numbers = made, itertools.count(1)

        def make(_info: object) -> None:
            current[:] = (source.make(next(numbers)),)

        runner.add_pre_tick(make)
    recorder = None
    if traced is not None:
        recorder = TraceRecorder(traced, runner.tree, clock=clock)
        rec = recorder

        def hook(_info: object) -> None:
            rec.record_tick(current[0] if current else extras[rec.ticks])

        runner.add_post_tick(hook)
    start = time.perf_counter()
    result = runner.run()
    elapsed = time.perf_counter() - start
    if recorder is not None:
        recorder.close()
    return elapsed / max(1, result.ticks)


def overhead(
    ticks: int = 5000, repeats: int = 15, runner: bool = False, tree_kind: str = "sparse"
) -> tuple[list[float], list[float]]:
    """Seconds per tick without and with tracing, one value per run (runs alternate)."""
    plain: list[float] = []
    traced: list[float] = []
    with tempfile.TemporaryDirectory() as folder:
        for r in range(repeats):
            path = Path(folder) / f"b{r}.jsonl"
            # ABBA order (off, on, on, off, ...) cancels a machine that drifts faster or
            # slower during the benchmark.
            for traced_now in (False, True) if r % 2 == 0 else (True, False):
                if runner:
                    seconds = time_runner_ticks(ticks, path if traced_now else None, tree_kind)
                elif traced_now:
                    tree = fifty_node_tree()
                    with TraceRecorder(path, tree, clock=SimClock()) as rec:
                        seconds = time_ticks(tree, ticks, rec)
                else:
                    seconds = time_ticks(fifty_node_tree(), ticks, None)
                (traced if traced_now else plain).append(seconds)
    return plain, traced


def report(label: str, plain: list[float], traced: list[float]) -> tuple[float, ...]:
    """Print median and range of the tick times and of the overhead; return them.

    Returns:
        Seconds per tick untraced and traced (medians), the median extra seconds,
        the median extra % and its range.
    """
    p, t = statistics.median(plain), statistics.median(traced)
    extra = [b - a for a, b in zip(plain, traced, strict=True)]
    pct = [(b - a) / a * 100 for a, b in zip(plain, traced, strict=True)]
    print(
        f"{label}, tick alone:   {p * 1e6:7.1f} us/tick (range {min(plain) * 1e6:.1f}-"
        f"{max(plain) * 1e6:.1f})"
    )
    print(
        f"{label}, tick + trace: {t * 1e6:7.1f} us/tick (range {min(traced) * 1e6:.1f}-"
        f"{max(traced) * 1e6:.1f})"
    )
    print(
        f"{label}, overhead:     {statistics.median(extra) * 1e6:+7.1f} us/tick = "
        f"{statistics.median(pct):+.1f} % (range {min(pct):+.1f} to {max(pct):+.1f} %; "
        f"target <= 15 %)"
    )
    return p, t, statistics.median(extra), statistics.median(pct), min(pct), max(pct)


def size_per_hour(suffix: str, seconds: float = 60.0) -> float:
    """Bytes per hour of a simulated run written as ``suffix``."""
    ticks = int(seconds / TICK_S)
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / f"run{suffix}"
        record_pab_ticks(path, ticks)
        return path.stat().st_size * 3600.0 / seconds


class _PostTickTimer:
    """Times the runner's post-tick hooks (where the trace is recorded), per run."""

    def __init__(self) -> None:
        self.seconds = 0.0
        self._run = Runner.run

    def __enter__(self) -> _PostTickTimer:
        timer, run = self, self._run

        def timed_run(runner: Runner) -> Any:
            hooks = list(runner.post_tick)

            def post(info: Any) -> None:
                start = time.perf_counter()
                for hook in hooks:
                    hook(info)
                timer.seconds += time.perf_counter() - start

            runner.post_tick = [post]
            return run(runner)

        Runner.run = timed_run  # type: ignore[method-assign]
        return self

    def __exit__(self, *exc: object) -> None:
        Runner.run = self._run  # type: ignore[method-assign]


def simulated_run(
    tree_file: str, network: str, params: dict[str, str], trace: bool
) -> tuple[float, float]:
    """Wall seconds per tick of a whole simulated run, and of those in the post-tick hooks.

    This is the tick a user of ``pirate-bt run --trace`` pays for in simulation: the
    runner ticks the tree at 20 Hz, the supervisor checks every command, the link
    encodes and decodes frames, and the in-process simulator steps its physics.
    """
    from pirate_bt.robot import load_robot
    from pirate_bt.runner import Runner
    from pirate_bt.safety.factory import open_supervisor
    from pirate_bt.trace import attach_trace, supervised_extras
    from pirate_bt.treefile import load_tree

    repo = Path(__file__).resolve().parent.parent
    robot = load_robot()
    clock = SimClock()
    sup = open_supervisor(robot, clock=clock, network=network, seed=1)
    try:
        loaded = load_tree(
            repo / tree_file,
            robot=robot,
            clock=clock,
            supervisor=sup,
            params=params,
            params_from_text=True,
        )
        runner = Runner(loaded, clock=clock, period_s=0.05, max_time_s=300)
        runner.add_pre_tick(lambda _info: sup.tick())
        with tempfile.TemporaryDirectory() as tmp:
            if trace:
                counters = sup.simulator.counters if sup.simulator is not None else None
                attach_trace(
                    runner,
                    Path(tmp) / "run.jsonl",
                    extras=supervised_extras(sup, counters=counters),
                    robot=robot,
                )
            start = time.perf_counter()
            with _PostTickTimer() as hooks:
                result = runner.run()
            wall = time.perf_counter() - start
        if not result.succeeded:
            raise RuntimeError(f"{tree_file} did not succeed: {result.message}")
        return wall / result.ticks, hooks.seconds / result.ticks
    finally:
        sup.close()


def report_simulated(
    name: str, tree_file: str, network: str, params: dict[str, str], pairs: int = 15
) -> tuple[float, ...]:
    """Median and quartiles of the per-pair overhead of alternating untraced/traced runs.

    Returns:
        Seconds per tick untraced and traced (medians), the quartiles of the per-pair
        %, the extra seconds per tick in the post-tick hooks, and the pairs.
    """
    off, on, hook_off, hook_on = [], [], [], []
    for pair in range(pairs):  # ABBA order, as in overhead()
        for traced_now in (False, True) if pair % 2 == 0 else (True, False):
            seconds, in_hooks = simulated_run(tree_file, network, params, trace=traced_now)
            (on if traced_now else off).append(seconds)
            (hook_on if traced_now else hook_off).append(in_hooks)
    base, traced = statistics.median(off), statistics.median(on)
    pct = sorted((b - a) / a * 100 for a, b in zip(off, on, strict=True))
    q1, q2, q3 = statistics.quantiles(pct, n=4)
    in_hook = statistics.median(hook_on) - statistics.median(hook_off)
    print(
        f"{name:<30} tick {base * 1e6:5.0f} us -> {traced * 1e6:5.0f} us with trace:"
        f" {(traced - base) * 1e6:+5.0f} us; per pair {q2:+5.1f} % (quartiles {q1:+.1f}"
        f" to {q3:+.1f} %, {pairs} pairs; target <= 15 %); in the post-tick hooks"
        f" {in_hook * 1e6:+.0f} us, {in_hook / base * 100:+.1f} %"
    )
    return base, traced, q1, q2, q3, in_hook, pairs


def report_open_close(runs: int = 15) -> tuple[float, float, int]:
    """What a run pays once: opening a trace (the writer process starts) and closing it."""
    opened, closed = [], []
    with tempfile.TemporaryDirectory() as folder:
        for r in range(runs):
            tree = fifty_node_tree()
            clock = SimClock()
            start = time.perf_counter()
            rec = TraceRecorder(Path(folder) / f"oc{r}.jsonl", tree, clock=clock)
            opened.append(time.perf_counter() - start)
            for _ in range(100):
                clock.advance(TICK_S)
                tree.tick()
                rec.record_tick()
            time.sleep(0.1)  # a run goes on for a while: the writer process is up
            start = time.perf_counter()
            rec.close()
            closed.append(time.perf_counter() - start)
    print(
        f"open a trace (writer process starts): {statistics.median(opened) * 1e3:.1f} ms;"
        f" close it (everything on disk): {statistics.median(closed) * 1e3:.1f} ms"
        f" (medians of {runs})"
    )
    return statistics.median(opened), statistics.median(closed), runs


def report_mission(pairs: int = 5) -> dict[str, float]:
    """The demo's whole lab mission with and without its trace, and the trace's size."""
    from bench_mission import one_run

    pct: list[float] = []
    direct: list[float] = []
    hook_us: list[float] = []
    size = sim_s = 0.0
    for pair in range(pairs):
        wall: dict[bool, float] = {}
        hooks: dict[bool, float] = {}
        for traced_now in (False, True) if pair % 2 == 0 else (True, False):  # ABBA order
            with tempfile.TemporaryDirectory() as tmp, _PostTickTimer() as timer:
                wall[traced_now], sim_s, ticks = one_run(Path(tmp), trace=traced_now)
                if traced_now:
                    size = (Path(tmp) / "trace.jsonl").stat().st_size
            hooks[traced_now] = timer.seconds
        off, on = wall[False], wall[True]
        in_hook = hooks[True] - hooks[False]
        pct.append((on - off) / off * 100)
        direct.append(in_hook / off * 100)
        hook_us.append(in_hook / ticks * 1e6)
        print(
            f"lab mission ({ticks} ticks, {sim_s:.0f} s simulated): {off:.2f} s -> {on:.2f} s"
            f" with trace, {(on - off) / ticks * 1e6:+.0f} us/tick, {pct[-1]:+.1f} %;"
            f" in the post-tick hooks {in_hook / ticks * 1e6:+.0f} us/tick, {direct[-1]:+.1f} %"
        )
    with tempfile.TemporaryDirectory() as tmp:
        one_run(Path(tmp), trace=True, suffix=".jsonl.gz")
        packed = (Path(tmp) / "trace.jsonl.gz").stat().st_size
    print(
        f"lab mission, overhead: median {statistics.median(pct):+.1f} % of wall time"
        f" (range {min(pct):+.1f} to {max(pct):+.1f}), {statistics.median(direct):+.1f} % spent"
        f" in the trace's hook, over {pairs} pairs (target <= 15 %)"
    )
    for label, nbytes in ((".jsonl", size), (".jsonl.gz", packed)):
        print(
            f"lab mission trace ({label:<9}): {nbytes / 1e6:5.2f} MB ="
            f" {nbytes * 3600 / sim_s / 1e6:6.1f} MB per hour of PAB runs (20 Hz ticks)"
        )
    return {
        "ticks": ticks,
        "sim_s": sim_s,
        "pairs": pairs,
        "pct": statistics.median(pct),
        "pct_min": min(pct),
        "pct_max": max(pct),
        "hook_us": statistics.median(hook_us),
        "hook_pct": statistics.median(direct),
        "jsonl_per_h": size * 3600 / sim_s,
        "gz_per_h": packed * 3600 / sim_s,
    }


def main() -> None:
    issue6 = report("50-node tree (issue 6), Runner", *overhead(runner=True, tree_kind="issue6"))
    sparse = report("sparse 50-node tree, tree.tick()", *overhead())
    sparse_runner = report("sparse 50-node tree, Runner", *overhead(runner=True))
    bend = report_simulated(
        "bend PAB, simulated run", "trees/bend.yaml", "bend-right", {"roll": "90 deg"}
    )
    straight = report_simulated(
        "straight PAB, simulated run", "trees/straight.yaml", "straight", {"distance": "1.5 m"}
    )
    open_close = report_open_close()
    mission = report_mission()
    sizes = {}
    for suffix in (".jsonl", ".jsonl.gz"):
        size = size_per_hour(suffix)
        sizes[suffix] = size
        print(f"trace size per hour ({suffix:<9}): {size / 1e6:8.1f} MB  (10 ms ticks)")
    publish_table(issue6, sparse, sparse_runner, bend, straight, open_close, mission, sizes)


TARGET_PCT = 15.0
"""The target for the trace's cost per tick (docs/performance.md, Trace)."""


def publish_table(
    issue6: tuple[float, ...],
    sparse: tuple[float, ...],
    sparse_runner: tuple[float, ...],
    bend: tuple[float, ...],
    straight: tuple[float, ...],
    open_close: tuple[float, float, int],
    mission: dict[str, float],
    sizes: dict[str, float],
) -> None:
    """The figures above as the table docs/performance.md shows under Trace."""
    from report import publish

    def per_tick(figures: tuple[float, ...], bold: bool = False) -> str:
        plain, traced, extra, pct = figures[:4]
        cost = f"{extra * 1e6:+.1f} µs, {pct:+.1f} %"
        return f"{plain * 1e6:.1f} → {traced * 1e6:.1f} µs: " + (f"**{cost}**" if bold else cost)

    def target(figures: tuple[float, ...]) -> str:
        return f"≤ {TARGET_PCT:g} %: " + ("**met**" if figures[3] <= TARGET_PCT else "not met")

    def whole(figures: tuple[float, ...]) -> str:
        base, traced, q1, q2, q3, in_hook, _ = figures
        return (
            f"{base * 1e6:.0f} → {traced * 1e6:.0f} µs: {q2:+.1f} % per pair (quartiles"
            f" {q1:+.1f} to {q3:+.1f} %); in the hooks {in_hook * 1e6:+.0f} µs,"
            f" {in_hook / base * 100:+.1f} %"
        )

    opened, closed, oc_runs = open_close
    rows = [
        [
            "**the 50-node tree** (the tree-engine figure's: from YAML, guards, via the runner),"
            " tick → tick + trace",
            per_tick(issue6, bold=True),
            target(issue6),
        ],
        ["sparse 50-node tree, do-nothing leaves, `tree.tick()`", per_tick(sparse), target(sparse)],
        ["sparse 50-node tree via the runner", per_tick(sparse_runner), target(sparse_runner)],
        ["bend PAB, whole simulated run (runner, supervisor, link, simulator)", whole(bend), ""],
        ["straight PAB, whole simulated run", whole(straight), ""],
        [
            f"the demo's lab mission ({mission['ticks']:,.0f} ticks,"
            f" {mission['sim_s']:.0f} s simulated)",
            f"{mission['pct']:+.1f} % of wall time ({mission['pairs']:.0f} pairs,"
            f" {mission['pct_min']:+.1f} to {mission['pct_max']:+.1f} %); in the hooks"
            f" {mission['hook_us']:+.0f} µs per tick, {mission['hook_pct']:+.1f} %",
            "",
        ],
        [
            "opening / closing a trace (once per run)",
            f"{opened * 1e3:.1f} ms / {closed * 1e3:.1f} ms",
            "",
        ],
        [
            "trace size per hour of PAB runs (the lab mission: 20 Hz ticks, 100 Hz state),"
            " `.jsonl` / `.jsonl.gz`",
            f"**{mission['jsonl_per_h'] / 1e6:.1f} MB / {mission['gz_per_h'] / 1e6:.1f} MB**",
            "",
        ],
        [
            "trace size per hour, synthetic worst case (a record every 10 ms tick, 10 state"
            " values moving each tick), `.jsonl` / `.jsonl.gz`",
            f"{sizes['.jsonl'] / 1e6:.0f} MB / {sizes['.jsonl.gz'] / 1e6:.1f} MB",
            "",
        ],
    ]
    publish(
        "trace",
        ["figure", "now", "target"],
        rows,
        note=f"Per-tick rows: the median over ABBA pairs of runs traced and untraced; PAB"
        f" rows: {bend[6]:.0f} ABBA pairs of whole runs, median and quartiles of the per-pair"
        f" ratio, and the time inside the runner's post-tick hooks; the mission:"
        f" {mission['pairs']:.0f} ABBA pairs; opening and closing: medians of {oc_runs}.",
    )


if __name__ == "__main__":
    from report import no_arguments

    no_arguments(__doc__)
    main()
