"""Foundation figures: CLI cold start and robot description load+validate.

Run: ``.venv/bin/python benchmarks/bench_foundation.py`` (or ``make bench``).
Targets (issue 2): ``pirate-bt --help`` cold start < 0.3 s; load+validate of
``hardware/pirate.yaml`` < 20 ms.
"""

from __future__ import annotations

import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent


def _time_command(argv: list[str], runs: int) -> list[float]:
    times = []
    for _ in range(runs):
        start = time.perf_counter()
        subprocess.run(argv, check=True, capture_output=True)
        times.append(time.perf_counter() - start)
    return times


def _summary(name: str, samples: list[float], unit: float, suffix: str) -> None:
    ordered = sorted(samples)
    p90 = ordered[int(0.9 * (len(ordered) - 1))]
    print(
        f"{name:<44} median {statistics.median(samples) * unit:8.2f} {suffix}"
        f"   p90 {p90 * unit:8.2f} {suffix}   (n={len(samples)})"
    )


def main() -> None:
    script = shutil.which("pirate-bt", path=str(Path(sys.executable).parent))
    if script:
        _time_command([script, "--help"], 2)  # warm the OS file cache
        _summary("cold start: pirate-bt --help", _time_command([script, "--help"], 20), 1e3, "ms")
    _summary(
        "cold start: python -m pirate_bt --help",
        _time_command([sys.executable, "-m", "pirate_bt", "--help"], 20),
        1e3,
        "ms",
    )
    _summary(
        "bare interpreter: python -c pass",
        _time_command([sys.executable, "-c", "pass"], 20),
        1e3,
        "ms",
    )
    probe = (
        "import time; t=time.perf_counter(); "
        "from pirate_bt.robot import load_robot; load_robot(); "
        "print(time.perf_counter()-t)"
    )
    cold = []
    for _ in range(10):
        out = subprocess.run([sys.executable, "-c", probe], check=True, capture_output=True)
        cold.append(float(out.stdout))
    _summary("first load+validate incl. imports (fresh proc)", cold, 1e3, "ms")

    from pirate_bt.robot import load_robot

    path = REPO / "hardware" / "pirate.yaml"
    load_robot(path)
    warm = []
    for _ in range(50):
        start = time.perf_counter()
        load_robot(path)
        warm.append(time.perf_counter() - start)
    _summary("load+validate hardware/pirate.yaml (warm)", warm, 1e3, "ms")

    # The units library we did not take: pint's import + registry, for comparison.
    try:
        pint_times = _time_command([sys.executable, "-c", "import pint; pint.UnitRegistry()"], 3)
        _summary("pint import + UnitRegistry (comparison)", pint_times, 1e3, "ms")
    except subprocess.CalledProcessError:
        print("pint import + UnitRegistry (comparison): pint is not installed in this environment")


if __name__ == "__main__":
    main()
