"""Peak memory of reading a large trace back: ``.jsonl`` against ``.mcap``.

Run: ``.venv/bin/python benchmarks/bench_trace_read.py [TICKS] [--tree DIR]
[--keep DIR]`` (default 100,000 ticks). ``--tree DIR`` reads with another source
tree of pirate_bt (``git archive COMMIT | tar -x -C DIR``), with this tree's
virtual environment, to compare a change with what came before on the same
machine and the same files. ``--keep DIR`` writes the traces there and reuses
them when they are there already (making them takes a minute or two).

The trace is the trace benchmark's synthetic run (``bench_trace.py``'s sparse
50-node tree, a plausible robot state every tick, a command every 10th tick),
written by the recorder as ``.jsonl`` and converted with ``pirate-bt trace
export`` to ``.mcap`` (chunked, LZ4, indexed), so both hold the same records.
Each file is read in a fresh Python process by :func:`pirate_bt.read_trace` (what
``pirate-bt trace show|summary|plot`` call); the figures are that process's peak
resident set (``ru_maxrss``), its resident set once ``pirate_bt`` and the ``mcap``
package are imported (the floor), the difference, and the wall time of the read.
Also per file: the bytes of the file read before the reader's first record (the
``.mcap`` reader used to read the whole file first).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
from datetime import date
from pathlib import Path

from trace_inputs import record_pab_ticks

REPO = Path(__file__).resolve().parent.parent

# Run in a fresh process: the figures of one read, nothing else held.
_PROBE = r"""
import json, resource, sys, time
from pathlib import Path
import pirate_bt
import pirate_bt.trace.format_readers as formats
try:
    import pirate_bt.interop.mcap_trace  # noqa: F401 (registers .mcap)
    import mcap.stream_reader  # noqa: F401
except ImportError:
    pass
path = Path(sys.argv[1])
kib = 1024 if sys.platform != "darwin" else 1
floor = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * kib
read = 0
real_open = open

class Counting:
    def __init__(self, stream):
        self.stream = stream
    def __getattr__(self, name):
        return getattr(self.stream, name)
    def __enter__(self):
        return self
    def __exit__(self, *exc):
        self.stream.close()
    def read(self, *args):
        global read
        data = self.stream.read(*args)
        read += len(data)
        return data
    def readline(self, *args):
        global read
        data = self.stream.readline(*args)
        read += len(data)
        return data

def counted(file, mode="r", *args, **kwargs):
    stream = real_open(file, mode, *args, **kwargs)
    return Counting(stream) if "b" in mode and Path(file) == path else stream

reader = formats.open_reader(path)
if reader.__class__.__name__ == "McapTraceReader":
    import builtins
    builtins.open = counted
else:
    reader._open = (lambda opened: lambda: Counting(opened()))(reader._open)
first_at = -1
for _ in reader:
    first_at = read
    break
import builtins
builtins.open = real_open
del reader
start = time.perf_counter()
trace = pirate_bt.read_trace(path)
seconds = time.perf_counter() - start
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * kib
print(json.dumps({"floor": floor, "peak": peak, "seconds": seconds,
                  "ticks": len(trace.ticks), "first_at": first_at}))
"""


def _cpu() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.partition(":")[2].strip()
    except OSError:
        pass
    return platform.processor() or "?"


def make_traces(folder: Path, ticks: int) -> tuple[Path, Path]:
    """The ``.jsonl`` trace of ``ticks`` ticks and its ``.mcap`` export, in ``folder``."""
    jsonl, mcap = folder / f"read-{ticks}.jsonl", folder / f"read-{ticks}.mcap"
    if not jsonl.exists():
        partial = jsonl.with_suffix(".part.jsonl")
        record_pab_ticks(partial, ticks)
        partial.rename(jsonl)
    if not mcap.exists():
        from pirate_bt.interop.mcap_trace import export_mcap

        export_mcap(jsonl, mcap)
    return jsonl, mcap


def measure(path: Path, tree: Path | None) -> dict[str, float]:
    """One read of ``path`` in a fresh process, with ``tree``'s pirate_bt if given."""
    env = dict(os.environ)
    if tree is not None:
        env["PYTHONPATH"] = str(tree)
    done = subprocess.run(
        [sys.executable, "-c", _PROBE, str(path)],
        env=env,
        cwd=tree or REPO,
        capture_output=True,
        text=True,
        check=True,
    )
    figures: dict[str, float] = json.loads(done.stdout.strip().splitlines()[-1])
    return figures


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("ticks", nargs="?", type=int, default=100_000)
    parser.add_argument("--tree", type=Path, help="read with this source tree's pirate_bt")
    parser.add_argument("--keep", type=Path, help="write (and reuse) the traces here")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as scratch:
        folder = args.keep or Path(scratch)
        folder.mkdir(parents=True, exist_ok=True)
        jsonl, mcap = make_traces(folder, args.ticks)
        tree = args.tree.resolve() if args.tree else None
        print(
            f"*Measured on {date.today()}, {os.cpu_count()} cores, {_cpu()},"
            f" Python {platform.python_version()}, {platform.system()} {platform.release()},"
            f" load average {os.getloadavg()[0]:.2f}: `.venv/bin/python"
            f" benchmarks/bench_trace_read.py {args.ticks}"
            + (f" --tree {args.tree}" if args.tree else "")
            + "`.*\n"
        )
        print(
            "| file | size | peak RSS | after import | read's own | read time"
            " | first record after |"
        )
        print("|---|---|---|---|---|---|---|")
        for path in (jsonl, mcap):
            f = measure(path, tree)
            mb = 1e6
            print(
                f"| `{path.suffix}`, {int(f['ticks']):,} ticks | {path.stat().st_size / mb:.1f} MB"
                f" | {f['peak'] / mb:.0f} MB | {f['floor'] / mb:.0f} MB"
                f" | **{(f['peak'] - f['floor']) / mb:.0f} MB** | {f['seconds']:.1f} s"
                f" | {f['first_at'] / mb:.2f} MB read |"
            )


if __name__ == "__main__":
    main()
