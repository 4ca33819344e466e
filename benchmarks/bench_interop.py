"""Foxglove figures: MCAP size per hour, and the cost of ``--trace RUN.mcap`` and ``--foxglove``.

Run: ``.venv/bin/python benchmarks/bench_interop.py [PAIRS] [--tree DIR]
[--no-sizes] [--only mcap,foxglove,jsonl]`` (default 3 ABBA pairs). ``--tree DIR``
runs the commands from another source tree of pirate_bt (``git archive COMMIT |
tar -x -C DIR``), with this tree's virtual environment, to compare a change with
what came before on the same machine. With ``--tree`` or ``--only`` the overhead
table is printed, not published (``make bench`` keeps the page's table).

- **Size per hour**: the lab mission (``pirate-bt mission scenarios/lab.route
  --sim lab --quiet --trace X``) written once per suffix (``.jsonl``,
  ``.jsonl.gz``, ``.mcap``), scaled from its simulated duration to an hour. The
  ``.mcap`` is the file as the run leaves it (compacted: chunked, LZ4, indexed);
  the size of the unchunked file before compaction, which is what a killed run
  leaves, is measured from the recorder's writer with compaction off.
- **Overhead** of ``--trace RUN.mcap``, ``--foxglove`` and, for comparison,
  ``--trace RUN.jsonl`` (the floor: the same capture in the tick, the cheapest
  writer process): wall time of the whole command (start-up included, the same
  on both sides) against the same command without them, in ABBA order (off, on,
  on, off) repeated, so that a noisy, shared machine hits both alike. The figure
  is the extra wall time per run, median and range over the pairs, also as % of
  the plain run's median, and each pair's ratio (*on / off - 1*). For
  ``--foxglove`` one client (``tests/foxglove_ws.py``, standard library)
  connects as soon as the port opens, subscribes to every topic and reads
  everything until the run ends. The load average is printed as it goes.
"""

from __future__ import annotations

import argparse
import json
import os
import socket
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))
from report import publish  # noqa: E402 - benchmarks/ is this script's own folder

PIRATE_BT = str(Path(sys.executable).with_name("pirate-bt"))
MISSION = [PIRATE_BT, "mission", "scenarios/lab.route", "--sim", "lab", "--quiet"]
TREE = ROOT
"""The source tree whose pirate_bt runs (``--tree``; then nothing is published)."""
TARGET_PCT = 15.0
"""Issue 27's target for ``--trace RUN.mcap`` and ``--foxglove``."""
SIZE_LABELS = {
    ".jsonl": "`.jsonl`",
    ".jsonl.gz": "`.jsonl.gz`",
    ".mcap": "`.mcap` (as a finished run leaves it: chunked, LZ4, indexed)",
    ".mcap unchunked (while running)": "`.mcap` while the run goes on (unchunked, what a"
    " SIGKILL leaves)",
}
OVERHEAD_LABELS = {
    "--trace RUN.mcap": "`--trace RUN.mcap`",
    "--foxglove, one client": "`--foxglove`, one client subscribed to every topic",
    "--trace RUN.jsonl": "`--trace RUN.jsonl`, for comparison (the floor)",
}


def _command() -> tuple[list[str], dict[str, str] | None]:
    if TREE == ROOT:
        return MISSION, None
    env = {**os.environ, "PYTHONPATH": str(TREE)}
    return [sys.executable, "-m", "pirate_bt", *MISSION[1:]], env


def _run(extra: list[str]) -> float:
    command, env = _command()
    started = time.perf_counter()
    subprocess.run([*command, *extra], cwd=TREE, check=True, capture_output=True, env=env)
    return time.perf_counter() - started


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def _run_with_client() -> tuple[float, int]:
    from foxglove_ws import FoxgloveClient

    from pirate_bt.interop.foxglove_topics import TOPICS

    port = _free_port()
    received = [0]
    command, env = _command()
    started = time.perf_counter()
    proc = subprocess.Popen(
        [*command, "--foxglove", f"127.0.0.1:{port}"],
        cwd=TREE,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        env=env,
    )

    def client() -> None:
        while proc.poll() is None:
            try:
                fox = FoxgloveClient("127.0.0.1", port)
                break
            except OSError:
                time.sleep(0.01)
        else:
            return
        fox.wait_for(lambda c: set(TOPICS) <= set(c.channels), 5)
        fox.subscribe(*TOPICS)
        try:
            while proc.poll() is None:
                fox.pump(0.1)
        except ConnectionError:
            pass
        received[0] = len(fox.messages)
        for end in fox.of("/pirate/end"):
            if end.get("dropped"):
                print(f"    (the live view merged {end['dropped']} ticks: its process lagged)")

    reader = threading.Thread(target=client, daemon=True)
    reader.start()
    proc.wait()
    took = time.perf_counter() - started
    reader.join(5)
    if proc.returncode != 0:
        raise RuntimeError(f"mission failed with --foxglove (exit {proc.returncode})")
    return took, received[0]


def sizes() -> None:
    """Print each format's size per hour, and publish the table."""
    print("Size per hour of the lab mission (20 Hz ticks):")
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        files = {suffix: out / f"lab{suffix}" for suffix in (".jsonl", ".jsonl.gz", ".mcap")}
        for path in files.values():
            _run(["--trace", str(path)])
        end = json.loads(files[".jsonl"].read_text().splitlines()[-1])
        hours = float(end["t_s"]) / 3600.0
        # The unchunked file a killed run leaves: the same records, compaction off.
        from pirate_bt.interop.mcap_trace import McapTraceWriter

        raw = McapTraceWriter(out / "raw.mcap", compact=False)
        for line in files[".jsonl"].read_text().splitlines():
            raw.write_line(line + "\n")
        raw.close()
        rows = [(s, p.stat().st_size) for s, p in files.items()]
        rows.append((".mcap unchunked (while running)", (out / "raw.mcap").stat().st_size))
        base = files[".jsonl"].stat().st_size
        print(f"  mission: {end['t_s']:.0f} s simulated, {end['n']} ticks")
        for name, size in rows:
            print(
                f"  {name:34s} {size / 1e6:7.2f} MB per run, {size / hours / 1e6:7.1f} MB/h"
                f"  ({size / base:.2f} x .jsonl)"
            )
    if TREE == ROOT:
        publish(
            "interop-size",
            ["format", "per run", "per hour", "against `.jsonl`"],
            [
                [
                    SIZE_LABELS.get(name, f"`{name}`"),
                    f"{size / 1e6:.2f} MB",
                    f"{size / hours / 1e6:.1f} MB",
                    f"{size / base:.2f}x",
                ]
                for name, size in rows
            ],
            note=f"The lab mission's trace ({end['t_s']:.0f} s simulated, {end['n']:,} ticks at"
            " 20 Hz) written by `pirate-bt mission scenarios/lab.route --sim lab --trace X`"
            " in each format, scaled to an hour.",
        )


NAMES = ["--trace RUN.mcap", "--foxglove, one client", "--trace RUN.jsonl"]
"""What ``overhead`` measures (``--only mcap,foxglove,jsonl`` picks some)."""


def overhead(pairs: int) -> None:
    """Print each option's overhead on the lab mission, and publish the table."""
    print(f"Overhead on the lab mission (wall time per run, {pairs} ABBA pairs):")
    table: list[list[str]] = []
    loads: list[float] = []
    plains: list[float] = []
    with tempfile.TemporaryDirectory() as tmp:
        for name in NAMES:
            base: list[float] = []
            extra: list[float] = []
            messages = 0
            for _ in range(pairs):
                for on in (False, True, True, False):
                    if not on:
                        base.append(_run([]))
                    elif name.startswith("--trace"):
                        suffix = name.split("RUN")[1]
                        extra.append(_run(["--trace", str(Path(tmp) / f"lab{suffix}")]))
                    else:
                        took, messages = _run_with_client()
                        extra.append(took)
            diffs = [
                (extra[2 * i] + extra[2 * i + 1] - base[2 * i] - base[2 * i + 1]) / 2
                for i in range(pairs)
            ]
            ratios = [
                (extra[2 * i] + extra[2 * i + 1]) / (base[2 * i] + base[2 * i + 1]) - 1
                for i in range(pairs)
            ]
            plain = statistics.median(base)
            median = statistics.median(diffs)
            print(
                f"  {name:24s} +{median:5.2f} s (range {min(diffs):+.2f} to {max(diffs):+.2f} s)"
                f" on {plain:.2f} s untraced (median), {100 * median / plain:+.0f} %"
                + (f"; client received {messages} messages" if messages else "")
            )
            print(
                f"  {'':24s} per pair {100 * statistics.median(ratios):+.1f} % (range"
                f" {100 * min(ratios):+.1f} to {100 * max(ratios):+.1f} %): "
                + ", ".join(f"{100 * r:+.1f}" for r in ratios)
                + f"; load average now {os.getloadavg()[0]:.2f}"
            )
            loads.append(os.getloadavg()[0])
            plains.append(plain)
            pct = 100 * median / plain
            label = OVERHEAD_LABELS[name]
            if messages:
                label += f" ({messages:,} messages)"
            target = ""
            if name != "--trace RUN.jsonl":
                target = f"≤ {TARGET_PCT:g} %: " + ("**met**" if pct <= TARGET_PCT else "not met")
            table.append(
                [
                    label,
                    f"**{pct:+.0f} %** ({median:+.2f} s on {plain:.2f} s)",
                    f"{100 * statistics.median(ratios):+.1f} % ({100 * min(ratios):+.1f} to"
                    f" {100 * max(ratios):+.1f} %)",
                    target,
                ]
            )
    if len(table) < len(OVERHEAD_LABELS):  # --only: the page's table keeps its three rows
        print("(not published: --only measured some of the rows)")
    elif TREE == ROOT:
        publish(
            "interop-overhead",
            [
                "option, on the lab mission",
                f"extra wall time, median of {pairs} pairs (over the plain run's median)",
                "per pair: median (range)",
                "target",
            ],
            table,
            note=f"Whole commands (`pirate-bt mission scenarios/lab.route --sim lab --quiet`,"
            f" start-up included) with and without the option, {pairs} ABBA pairs each; the"
            f" plain run took {min(plains):.1f}–{max(plains):.1f} s (medians per row); load"
            f" average {min(loads):.1f}–{max(loads):.1f} after each row (the benchmark's own"
            " processes included).",
        )


def _only(text: str) -> list[str]:
    """``--only mcap,foxglove``: the overhead rows to measure, by a word of their name."""
    words = [w.strip() for w in text.split(",") if w.strip()]
    known = ("mcap", "foxglove", "jsonl")
    unknown = [w for w in words if w not in known]
    if unknown or not words:
        raise argparse.ArgumentTypeError(
            f"{text!r}: expected some of {','.join(known)}, comma-separated"
        )
    return [n for n in NAMES if any(w in n for w in words)]


def main(argv: list[str] | None = None) -> int:
    global TREE
    from report import positive, skip_without

    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("pairs", nargs="?", type=positive, default=3, help="ABBA pairs (3)")
    parser.add_argument("--tree", type=Path, metavar="DIR", help="run another source tree")
    parser.add_argument("--no-sizes", action="store_true", help="skip the size per hour")
    parser.add_argument("--only", type=_only, metavar="mcap,foxglove,jsonl", help="these rows")
    args = parser.parse_args(argv)
    if args.tree is not None:
        if not (args.tree / "pirate_bt").is_dir():
            parser.error(f"--tree {args.tree}: not a source tree of pirate_bt (no pirate_bt/)")
        TREE = args.tree.resolve()
    print(f"pirate_bt from {TREE}; load average {os.getloadavg()[0]:.2f}")
    if args.only is not None:
        NAMES[:] = args.only
    if not args.no_sizes or NAMES != ["--trace RUN.jsonl"]:
        skip_without(["mcap", "foxglove"], "foxglove")
    if not args.no_sizes:
        sizes()
    overhead(args.pairs)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
