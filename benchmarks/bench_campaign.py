"""Campaign throughput: cases per minute for 1 and 2 local workers and a local Dask
cluster, and the per-case overhead against a single ``pirate-bt run``.

Run: ``.venv/bin/python benchmarks/bench_campaign.py [CASES]`` (default 8 cases of
the straight PAB, 0.5 m, drop 5 %). The overhead is (campaign wall time with one
worker / cases) minus the mean wall time of the same run as ``pirate-bt run``
(both include a Python start and the imports; the campaign adds the pool, a
child process per case and the rows).
"""

from __future__ import annotations

import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
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


def _campaign(spec: Path, out: Path, extra: list[str]) -> float:
    argv = [sys.executable, "-m", "pirate_bt", "campaign", str(spec), "--quiet"]
    start = time.perf_counter()
    subprocess.run([*argv, "--output", str(out), *extra], check=True, capture_output=True)
    return time.perf_counter() - start


def main() -> None:
    count = int(sys.argv[1]) if len(sys.argv) > 1 else 8
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        spec = folder / "bench.campaign.yaml"
        spec.write_text(SPEC.format(count=count), encoding="utf-8")
        singles = []
        for seed in range(min(count, 4)):
            start = time.perf_counter()
            subprocess.run(
                [sys.executable, "-m", "pirate_bt", "run", str(REPO / "trees/straight.yaml"),
                 "--sim", "straight", "--param", "distance=0.5m", "--faults", "drop=0.05",
                 "--seed", str(seed), "--quiet"],
                check=True, capture_output=True,
            )  # fmt: skip
            singles.append(time.perf_counter() - start)
        single = statistics.mean(singles)
        print(f"single pirate-bt run: {single:.2f} s wall (mean of {len(singles)})")
        results: dict[str, float] = {}
        for workers in (1, 2):
            wall = _campaign(spec, folder / f"w{workers}", ["--workers", str(workers)])
            results[f"{workers} local worker(s)"] = wall
        from distributed import LocalCluster

        with LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
        ) as cluster:
            wall = _campaign(spec, folder / "dask", ["--scheduler", cluster.scheduler_address])
            results["local Dask cluster (2 workers)"] = wall
        for name, wall in results.items():
            print(f"{name}: {count} cases in {wall:.1f} s = {60 * count / wall:.1f} cases/min")
        per_case = results["1 local worker(s)"] / count
        print(
            f"per-case overhead (1 worker): {per_case:.2f} s per case vs {single:.2f} s"
            f" for a single run: {per_case - single:+.2f} s"
        )


if __name__ == "__main__":
    main()
