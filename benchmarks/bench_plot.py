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

import argparse
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


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("trace", nargs="?", type=Path, help="a run's trace (default: run one)")
    args = parser.parse_args(argv)
    if args.trace is not None and not args.trace.is_file():
        print(f"error: {args.trace}: no such trace file", file=sys.stderr)
        return 2
    sys.path.insert(0, str(REPO / "benchmarks"))
    from report import skip_without

    skip_without(["matplotlib"], "plot")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot  # imported once, outside the timings

    from pirate_bt.cli import main as cli
    from pirate_bt.errors import PirateError
    from pirate_bt.render.plot import plot_series, plot_trace
    from pirate_bt.trace import read_trace

    if args.trace is not None:
        try:
            read_trace(args.trace)
        except PirateError as exc:
            print(f"error: {exc}", file=sys.stderr)
            return 2

    with tempfile.TemporaryDirectory() as tmp:
        if args.trace is not None:
            path = args.trace
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
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
