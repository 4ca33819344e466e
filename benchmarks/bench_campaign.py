"""Campaign cost per case, per executor, against a lone run of the same case in-process.

Run: ``.venv/bin/python benchmarks/bench_campaign.py [CASES] [ROUNDS]`` (default 16
cases of the straight PAB, 0.5 m, drop 5 %, and 3 rounds; the whole commands run
3 × CASES). Everything is measured in
one run, as ratios where the machine is noisy:

- **lone run**: :func:`pirate_bt.campaign.case.run_case` called in this process, warm
  (imports done, one run before), on each case of the campaign: what a case costs
  with no campaign around it;
- **fresh process per case** (the model before issue 27): the same case in a new
  ``python`` that imports and runs it, for comparison;
- **per-case overhead** of each executor with one worker (started before: the
  start of the pool, the cluster and the case servers is not counted): each case
  is run alone and through the executor side by side, in turn, and the overhead is
  the median of the differences over CASES x ROUNDS pairs (pairs cancel the
  machine's drift). Through the executor means from submitting the one case to
  holding its record, a round trip a running campaign overlaps with the case
  before it, so this is an upper bound. It is split into the time the case
  process itself measured (``wall_time_s``, the fork's copy-on-write included) and
  the rest (fork, pipes, the record's way back, the executor). The CPU time the
  case process, its server and the worker spent per case, against the lone run's
  (the mean over the pairs; it moves much less with the machine's load than wall
  time does) is printed beside it (Linux: read from ``/proc``);
- **throughput**: whole ``pirate-bt campaign`` commands with 2 local workers and on
  a local Dask cluster of 2 single-thread workers (started before, as a cluster
  is), interleaved over the rounds, in cases per minute (start-up included, as a
  user waits: the local pool starts its workers and their case servers every
  time; the cluster's servers start with the first campaign and stay), and
  their ratio.

It also prints the modules a case process still imported itself (none expected:
``pirate_bt.campaign.case.PRELOAD`` lists what a case server imports once).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from report import publish

HERE = Path(__file__).resolve().parent
TARGET_S = 0.05
"""Issue 27's target: what a case may cost beyond the run itself."""
RATIO_TARGET = 0.9
"""Issue 27's target: Dask's cases per minute against the local pool's."""
LABELS = {
    "local pool, 1 worker": "local pool, 1 worker",
    "Dask, 1 worker": "Dask (`LocalCluster`, 1 single-thread worker)",
}
SPEC = """\
name: bench
runs:
  - {{name: straight, tree: straight, network: straight, params: {{distance: 0.5 m}}}}
link:
  drop: [0.05]
seeds: {{start: 0, count: {count}}}
max_time: 120 s
keep_traces: none
"""


def imports_case(case: dict[str, Any], trace_dir: str | None) -> dict[str, Any]:
    """A case target (run in the case process): the case's record, and what it imported."""
    from pirate_bt.campaign.case import run_case

    before = set(sys.modules)
    record = run_case(case, trace_dir)
    record["imported"] = sorted(m for m in set(sys.modules) - before if not m.startswith("_"))
    times = os.times()  # a forked process's start at 0: this is the whole case process
    record["cpu_s"] = times.user + times.system
    record["server_pid"] = os.getppid()
    return record


def _cpu(pid: int) -> float:
    """A process's own CPU time so far (user and system), from /proc."""
    with open(f"/proc/{pid}/stat", encoding="ascii") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _parent(pid: int) -> int:
    with open(f"/proc/{pid}/stat", encoding="ascii") as f:
        return int(f.read().rsplit(")", 1)[1].split()[1])


def _spec_data(count: int) -> dict[str, Any]:
    import yaml

    data: dict[str, Any] = yaml.safe_load(SPEC.format(count=count))
    return data


_imported: set[str] = set()


Pair = tuple[float, float, float, float, float]


def _paired(executor: Any, cases: list[dict[str, Any]], target: str) -> list[Pair]:
    """Each case run alone in this process and through the executor, side by side.

    Returns:
        Per case: the lone run's wall and CPU time; the executor's wall time (from
        submitting the case to holding its record); the case process's own wall
        time (``wall_time_s``); the CPU time of the case process, its server and
        the worker (the executor's process) spent on the case.
    """
    from pirate_bt.campaign import run_cases

    def through(case: dict[str, Any]) -> tuple[float, float, float]:
        pids = _pids.get(id(executor), ())
        cpu = sum(_cpu(pid) for pid in pids)
        start = time.perf_counter()
        (row,) = run_cases([case], None, executor, target=target)
        wall = time.perf_counter() - start
        assert row["outcome"] == "success", row["reason"]
        _imported.update(row.get("imported", []))
        server = int(row["server_pid"])
        if not pids or pids[0] != server:  # the first case: learn the server and worker
            _pids[id(executor)] = (server, _parent(server))
            return wall, float(row["wall_time_s"]), math.nan
        cpu = sum(_cpu(pid) for pid in pids) - cpu + float(row["cpu_s"])
        return wall, float(row["wall_time_s"]), cpu

    pairs = []
    for i, case in enumerate(cases):
        if i % 2:  # alternate which goes first
            wall, inside, cpu = through(case)
            lone, lone_cpu = _lone(case)
        else:
            lone, lone_cpu = _lone(case)
            wall, inside, cpu = through(case)
        pairs.append((lone, lone_cpu, wall, inside, cpu))
    return pairs


_pids: dict[int, tuple[int, ...]] = {}


def _lone(case: dict[str, Any]) -> tuple[float, float]:
    """The case run in this process (warm): its wall and CPU time."""
    from pirate_bt.campaign.case import run_case

    start, cpu = time.perf_counter(), time.process_time()
    run_case(case, None)
    return time.perf_counter() - start, time.process_time() - cpu


def _command(spec: Path, out: Path, extra: list[str]) -> float:
    argv = [sys.executable, "-m", "pirate_bt", "campaign", str(spec), "--quiet"]
    start = time.perf_counter()
    subprocess.run([*argv, "--output", str(out), *extra], check=True, capture_output=True)
    return time.perf_counter() - start


def main(argv: list[str] | None = None) -> None:
    from report import positive, skip_without

    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("cases", nargs="?", type=positive, default=16, help="default 16")
    parser.add_argument("rounds", nargs="?", type=positive, default=3, help="default 3")
    args = parser.parse_args(argv)
    skip_without(["distributed"], "cluster")
    count = args.cases
    campaign = 3 * count  # cases of each whole command
    rounds = args.rounds
    os.environ["PYTHONPATH"] = os.pathsep.join(
        p for p in (str(HERE), os.environ.get("PYTHONPATH", "")) if p
    )
    load_before = os.getloadavg()
    from distributed import LocalCluster

    from pirate_bt.campaign import campaign_from_data, expand, make_executor
    from pirate_bt.campaign.case import run_case

    cases = expand(campaign_from_data(_spec_data(count)))
    target = "bench_campaign:imports_case"

    # A fresh Python per case, as campaigns ran before issue 27.
    run_case(cases[0], None)  # warm: the lone runs below are this process's second and later
    fresh = []
    code = (
        "import json, sys; from pirate_bt.campaign.case import run_case;"
        " run_case(json.load(sys.stdin))"
    )
    for case in cases[:4]:
        start = time.perf_counter()
        subprocess.run(
            [sys.executable, "-c", code],
            input=json.dumps(case),
            text=True,
            check=True,
            env=dict(os.environ, PYTHONHASHSEED="0"),
        )
        fresh.append(time.perf_counter() - start)
    fresh_s = statistics.mean(fresh)
    lone_fresh = statistics.mean(_lone(case)[0] for case in cases[:4])
    print(
        f"fresh process per case (before issue 27): {fresh_s:.3f} s per case,"
        f" {fresh_s - lone_fresh:+.3f} s over the lone run ({lone_fresh:.3f} s)"
    )

    # Per-case overhead with one worker, each executor: every case run alone and
    # through the executor side by side (the executors stay open: their start is
    # not counted; one case runs through each first, to start its server).
    names = ("local pool, 1 worker", "Dask, 1 worker")
    per_case: list[list[str]] = []
    found: dict[str, list[Pair]] = {name: [] for name in names}
    with (
        make_executor(workers=1) as (local_pool, _),
        LocalCluster(
            n_workers=1, threads_per_worker=1, processes=True, dashboard_address=None
        ) as cluster,
        make_executor(scheduler=cluster.scheduler_address) as (dask_pool, _),
    ):
        for executor in (local_pool, dask_pool):
            _paired(executor, cases[:1], target)
        for _ in range(rounds):
            for name, executor in zip(names, (local_pool, dask_pool), strict=True):
                found[name] += _paired(executor, cases, target)
    for name, pairs in found.items():
        over = [p[2] - p[0] for p in pairs]
        quart = statistics.quantiles(over, n=4) if len(over) > 1 else over * 3  # 1 case, 1 round
        inside = statistics.median(p[3] - p[0] for p in pairs)
        outside = statistics.median(p[2] - p[3] for p in pairs)
        cpu = statistics.mean(p[4] - p[1] for p in pairs)
        print(
            f"{name}: overhead {statistics.median(over):+.3f} s wall per case (median of"
            f" {len(pairs)} pairs, quartiles {quart[0]:+.3f} to {quart[2]:+.3f}) over a lone"
            f" run of {statistics.median(p[0] for p in pairs):.3f} s; inside the case process"
            f" {inside:+.3f} s, outside it {outside:+.3f} s; CPU {cpu:+.3f} s per case"
            f" (case process, server and worker, against the lone run's"
            f" {statistics.mean(p[1] for p in pairs):.3f} s)"
        )
        median = statistics.median(over)
        met = "**met**" if median <= TARGET_S else "not met"
        per_case.append(
            [
                LABELS[name],
                f"**{median:+.3f} s** ({quart[0]:+.3f} to {quart[2]:+.3f})",
                f"{cpu:+.3f} s",
                f"≤ {TARGET_S:g} s: {met}",
            ]
        )
        lone = statistics.median(p[0] for p in pairs)
        lone_cpu = statistics.mean(p[1] for p in pairs)
        n_pairs = len(pairs)

    print(
        "modules a case process imported itself:"
        f" {', '.join(sorted(_imported)) if _imported else 'none'}"
    )

    # Whole commands, 2 workers each, interleaved.
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        spec = folder / "bench.campaign.yaml"
        spec.write_text(SPEC.format(count=campaign), encoding="utf-8")
        local: list[float] = []
        dask: list[float] = []
        with LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
        ) as cluster:
            for i in range(rounds):
                local.append(_command(spec, folder / f"w2-{i}", ["--workers", "2"]))
                dask.append(
                    _command(spec, folder / f"dask-{i}", ["--scheduler", cluster.scheduler_address])
                )
    for name, walls in (("2 local workers", local), ("local Dask cluster, 2 workers", dask)):
        wall = statistics.median(walls)
        print(
            f"{name}: {campaign} cases in {wall:.2f} s (median of {len(walls)}:"
            f" {', '.join(f'{w:.2f}' for w in walls)}) = {60 * campaign / wall:.0f} cases/min"
        )
    ratios = [a / b for a, b in zip(local, dask, strict=True)]
    print(
        f"Dask against the local pool: {statistics.median(ratios):.2f}x cases/min, median"
        f" (per round: {', '.join(f'{r:.2f}' for r in ratios)}; in the first, the cluster's"
        " case servers start; later campaigns find them ready)"
    )
    load_after = os.getloadavg()
    print(
        f"load average {load_before[0]:.2f} {load_before[1]:.2f} before,"
        f" {load_after[0]:.2f} {load_after[1]:.2f} after (1 and 5 min)"
    )
    load = f"load average {load_before[0]:.1f} before, {load_after[0]:.1f} after"
    publish(
        "campaign-case",
        [
            "per case, beyond the run itself",
            f"wall, median of {n_pairs} pairs (quartiles)",
            f"CPU, mean of {n_pairs}",
            "target",
        ],
        [
            *per_case,
            [
                f"a fresh Python per case (the model before issue 27; mean of {len(fresh)})",
                f"{fresh_s - lone_fresh:+.2f} s",
                "-",
                "",
            ],
        ],
        note=f"The straight PAB (0.5 m, 5 % frame drop, `keep_traces: none`), {count} cases"
        f" × {rounds} rounds per executor, each case run alone in the benchmark's process"
        f" (warm) and through the executor in turn; the lone run took {lone:.3f} s of wall"
        f" and {lone_cpu:.3f} s of CPU. Modules a case process imported itself:"
        f" {', '.join(sorted(_imported)) if _imported else 'none'}; {load}.",
    )
    dask_ratio = statistics.median(ratios)
    publish(
        "campaign-throughput",
        ["how", f"{campaign} cases, median of {rounds}", "cases per minute"],
        [
            [
                "`--workers 2` (local process pool)",
                f"{statistics.median(local):.2f} s ({', '.join(f'{w:.2f}' for w in local)})",
                f"{60 * campaign / statistics.median(local):.0f}",
            ],
            [
                "`--scheduler` to a local Dask cluster (2 single-thread worker processes)",
                f"{statistics.median(dask):.2f} s ({', '.join(f'{w:.2f}' for w in dask)})",
                f"{60 * campaign / statistics.median(dask):.0f}",
            ],
            [
                "Dask against the local pool (median of the rounds' ratios)",
                f"per round {', '.join(f'{r:.2f}' for r in ratios)}",
                f"**{dask_ratio:.2f}x** (target {RATIO_TARGET:g}x:"
                f" {'**met**' if dask_ratio >= RATIO_TARGET else 'not met'})",
            ],
        ],
        note=f"Whole `pirate-bt campaign` commands, start-up included as a user waits, the"
        f" rounds interleaved; the cluster is started before, as clusters are, so its case"
        f" servers start with its first campaign and stay; {load}.",
    )


if __name__ == "__main__":
    main()
