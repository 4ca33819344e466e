"""The built-in navigators compared on as-built variants of the lab network.

One campaign (:func:`pirate_bt.run_campaign`) runs, on the same as-built variants of
``scenarios/lab.yaml`` (the ``as_built`` axis: the map is the drawing, the simulator
runs the variant) and the same seeds:

- ``mission``: ``scenarios/lab.route`` as one planned mission (the reference);
- ``route``: the same route file, followed step by step by the ``route`` navigator;
- ``goal``: the ``goal`` navigator told only the last segment (``riser``), re-planning
  from its belief after every step.

It prints the campaign's table (success with 95 % Wilson intervals, steps, clock
seconds per metre), the stops by cause, and the wall time; docs/navigators.md keeps
the table.

    .venv/bin/python benchmarks/bench_navigators.py            # 20 variants at x1
    .venv/bin/python benchmarks/bench_navigators.py -n 50 --scale 2 --workers 2
"""

from __future__ import annotations

import argparse
import logging
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent


def main(argv: list[str] | None = None) -> int:
    from report import positive, positive_number

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-n", "--variants", type=positive, default=20, help="as-built variants")
    parser.add_argument(
        "--scale", type=positive_number, default=1.0, help="times the as-built bounds"
    )
    parser.add_argument("--workers", type=positive, default=2, help="case processes at once")
    parser.add_argument("--output", type=Path, help="keep the campaign's folder here")
    args = parser.parse_args(argv)
    logging.disable(logging.WARNING)
    from pirate_bt import run_campaign
    from pirate_bt.campaign import campaign_from_data

    scenarios = REPO / "scenarios"
    spec = campaign_from_data(
        {
            "name": "navigators",
            "description": "The built-in navigators on as-built variants of the lab network.",
            "runs": [
                {"name": "mission", "route": str(scenarios / "lab.route")},
                {
                    "name": "route",
                    "navigator": "route",
                    "network": str(scenarios / "lab.yaml"),
                    "params": {"route": str(scenarios / "lab.route")},
                },
                {
                    "name": "goal",
                    "navigator": "goal",
                    "network": str(scenarios / "lab.yaml"),
                    "params": {"segment": "riser"},
                },
            ],
            "as_built": {"count": args.variants, "first": 1, "scale": args.scale},
            "max_time": "1500 s",
            "case_timeout": "600 s",
            "keep_traces": "none",
        }
    )
    with tempfile.TemporaryDirectory() as tmp:
        output = args.output or Path(tmp) / "navigators"
        started = time.perf_counter()
        result = run_campaign(spec, output=output, workers=args.workers)
        wall = time.perf_counter() - started
        report = (output / "report.md").read_text(encoding="utf-8")
    table = [line for line in report.splitlines() if line.startswith("|")]
    reasons = report.split("## Most frequent failure reasons", 1)[1].split("##", 1)[0]
    print(
        f"{args.variants} as-built variants of the lab network at x{args.scale:g} the bounds,"
        f" {result.cases} runs in {wall:.0f} s wall ({args.workers} workers)"
    )
    print()
    # the table without the link columns' group suffix and the counter table
    for line in table:
        if line.startswith("| counter"):
            break
        print(line.replace(" drop=0 corrupt=0 dup=0", ""))
    print()
    print("Stops by cause:" + reasons.rstrip())
    return 0


if __name__ == "__main__":
    sys.exit(main())
