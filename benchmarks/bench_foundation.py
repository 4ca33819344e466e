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

from report import publish

REPO = Path(__file__).resolve().parent.parent
RUNS = 20
"""Runs of each cold-start command."""


def _time_command(argv: list[str], runs: int) -> list[float]:
    times = []
    for _ in range(runs):
        start = time.perf_counter()
        subprocess.run(argv, check=True, capture_output=True)
        times.append(time.perf_counter() - start)
    return times


def _summary(name: str, samples: list[float], unit: float, suffix: str) -> tuple[float, float]:
    ordered = sorted(samples)
    p90 = ordered[int(0.9 * (len(ordered) - 1))]
    print(
        f"{name:<44} median {statistics.median(samples) * unit:8.2f} {suffix}"
        f"   p90 {p90 * unit:8.2f} {suffix}   (n={len(samples)})"
    )
    return statistics.median(samples) * unit, p90 * unit


def _ms(figure: tuple[float, float] | None, target_ms: float | None = None) -> str:
    if figure is None:
        return "not measured here"
    median, p90 = figure
    digits = 1 if median < 20 else 0
    text = f"{median:.{digits}f} ms median (p90 {p90:.{digits}f} ms)"
    if target_ms is not None:
        text += ": **met**" if median < target_ms else ": not met"
    return text


def main() -> None:
    figures: dict[str, tuple[float, float] | None] = {"script": None, "pint": None}
    script = shutil.which("pirate-bt", path=str(Path(sys.executable).parent))
    if script:
        _time_command([script, "--help"], 2)  # warm the OS file cache
        figures["script"] = _summary(
            "cold start: pirate-bt --help", _time_command([script, "--help"], RUNS), 1e3, "ms"
        )
    figures["module"] = _summary(
        "cold start: python -m pirate_bt --help",
        _time_command([sys.executable, "-m", "pirate_bt", "--help"], RUNS),
        1e3,
        "ms",
    )
    figures["bare"] = _summary(
        "bare interpreter: python -c pass",
        _time_command([sys.executable, "-c", "pass"], RUNS),
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
    figures["first"] = _summary("first load+validate incl. imports (fresh proc)", cold, 1e3, "ms")

    from pirate_bt.robot import load_robot

    path = REPO / "hardware" / "pirate.yaml"
    load_robot(path)
    warm = []
    for _ in range(50):
        start = time.perf_counter()
        load_robot(path)
        warm.append(time.perf_counter() - start)
    figures["warm"] = _summary("load+validate hardware/pirate.yaml (warm)", warm, 1e3, "ms")

    # The units library we did not take: pint's import + registry, for comparison.
    try:
        pint_times = _time_command([sys.executable, "-c", "import pint; pint.UnitRegistry()"], 3)
        figures["pint"] = _summary("pint import + UnitRegistry (comparison)", pint_times, 1e3, "ms")
    except subprocess.CalledProcessError:
        print("pint import + UnitRegistry (comparison): pint is not installed in this environment")

    publish(
        "foundation",
        ["figure", "target", "measured"],
        [
            ["cold start of `pirate-bt --help`", "< 300 ms", _ms(figures["script"], 300)],
            ["cold start of `python -m pirate_bt --help`", "-", _ms(figures["module"])],
            ["bare `python -c pass`, for reference", "-", _ms(figures["bare"])],
            [
                "load + validate `hardware/pirate.yaml`, warm",
                "< 20 ms",
                _ms(figures["warm"], 20),
            ],
            [
                "first load + validate in a fresh process, imports included",
                "-",
                _ms(figures["first"]),
            ],
            [
                "`import pint; pint.UnitRegistry()` (the units library we did not take)",
                "-",
                _ms(figures["pint"]) if figures["pint"] else "pint is not installed here",
            ],
        ],
        note=f"Cold starts: {RUNS} runs of each command (median and 90th percentile); the"
        " fresh-process load: 10 runs; the warm load: 50; pint: 3, when it is importable.",
    )


if __name__ == "__main__":
    from report import no_arguments

    no_arguments(__doc__)
    main()
