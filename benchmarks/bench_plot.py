"""Plot figures: building the series and drawing the lab mission's plot.

Run: ``.venv/bin/python benchmarks/bench_plot.py [TRACE]``. Without a trace it
first runs the lab mission on the simulator (``pirate-bt mission
scenarios/lab.route --output DIR``, a minute or two) and plots its trace.

Prints, as the median of five runs: reading the trace, building the series
(``plot_series``: one pass over the change records), and the whole
``plot_trace`` to PNG (matplotlib drawing included, its import not), for the
whole run and for a 30 s zoom.
"""

from __future__ import annotations

import statistics
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent


def _median(fn: Callable[[], object], runs: int = 5) -> float:
    times = []
    for _ in range(runs):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def main() -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot  # imported once, outside the timings

    from pirate_bt.cli import main as cli
    from pirate_bt.render.plot import plot_series, plot_trace
    from pirate_bt.trace import read_trace

    with tempfile.TemporaryDirectory() as tmp:
        if len(sys.argv) > 1:
            path = Path(sys.argv[1])
        else:
            out = Path(tmp) / "lab"
            cli(["mission", str(REPO / "scenarios" / "lab.route"), "-q", "--output", str(out)])
            path = out / "trace.jsonl"
        read_s = _median(lambda: read_trace(path), runs=3)
        trace = read_trace(path)
        series_s = _median(lambda: plot_series(trace))
        png = Path(tmp) / "plot.png"
        plot_s = _median(lambda: plot_trace(trace, png))
        zoom_s = _median(lambda: plot_trace(trace, png, start_s=75.0, end_s=105.0))
        series = plot_series(trace)
        print(f"trace           {path} ({trace.duration_s:.0f} s, {len(trace.ticks)} ticks)")
        print(f"PABs, steps     {len(series.pabs)}, {len(series.steps)}")
        print(f"read_trace      {read_s:.3f} s")
        print(f"plot_series     {series_s:.3f} s")
        print(f"plot (whole)    {plot_s:.3f} s")
        print(f"plot (30 s)     {zoom_s:.3f} s")


if __name__ == "__main__":
    main()
