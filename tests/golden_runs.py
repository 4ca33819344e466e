"""Recorded runs: the bytes on the wire and the trace of a few seeded runs, as digests.

A change that only makes pirate_bt faster must leave what a run does untouched:
the same bytes between host and bridge, and the same trace for the same seed.
``tests/data/golden/runs.json`` holds, per run, the SHA-256 and length of every
byte the host wrote and read (through :class:`pirate_bt.link.transport.Transport`)
and of the trace's records after the header (the header carries the date and
software versions). ``tests/test_golden_runs.py`` runs them again and compares.

Regenerate only for a change that is meant to alter runs, and say so in its commit:
``.venv/bin/python -m tests.golden_runs --write``.
"""

from __future__ import annotations

import argparse
import contextlib
import hashlib
import io
import json
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parent.parent
GOLDEN = REPO / "tests" / "data" / "golden" / "runs.json"

#: name -> the ``pirate-bt`` command line of the run (``--trace`` is added).
RUNS: dict[str, list[str]] = {
    "straight": ["run", "trees/straight.yaml", "--sim", "straight", "--param", "distance=1m"],
    "bend-faults": [
        "run",
        "trees/bend.yaml",
        "--param",
        "roll=90deg",
        "--sim",
        "bend-right",
        "--seed",
        "3",
        "--faults",
        "drop=0.05,corrupt=0.01",
    ],
    "t-joint-left": ["run", "trees/t-joint.yaml", "--param", "direction=left", "--sim", "t-joint"],
    "lab-mission": ["mission", "scenarios/lab.route", "--sim", "lab"],
}


@contextmanager
def wire_tap() -> Iterator[dict[str, Any]]:
    """Hash every byte the host writes to and reads from its transport."""
    from pirate_bt.link.transport import Transport

    digests = {"out": hashlib.sha256(), "in": hashlib.sha256()}
    sizes = {"out": 0, "in": 0}
    write, read_available = Transport.write, Transport.read_available

    def tapped_write(self: Transport, data: bytes) -> None:
        digests["out"].update(data)
        sizes["out"] += len(data)
        write(self, data)

    def tapped_read(self: Transport) -> bytes:
        data = read_available(self)
        digests["in"].update(data)
        sizes["in"] += len(data)
        return data

    Transport.write = tapped_write  # type: ignore[method-assign]
    Transport.read_available = tapped_read  # type: ignore[method-assign]
    result: dict[str, Any] = {}
    try:
        yield result
    finally:
        Transport.write = write  # type: ignore[method-assign]
        Transport.read_available = read_available  # type: ignore[method-assign]
        for side in ("out", "in"):
            result[f"wire_{side}_sha256"] = digests[side].hexdigest()
            result[f"wire_{side}_bytes"] = sizes[side]


def record(name: str) -> dict[str, Any]:
    """Run ``RUNS[name]`` in this process; its digests."""
    import py_trees

    from pirate_bt.cli import main

    # py_trees' blackboard is one per process: start each run from an empty one, as a
    # run of its own process does (the trace records blackboard writes).
    py_trees.blackboard.Blackboard.clear()
    with tempfile.TemporaryDirectory() as tmp:
        trace = Path(tmp) / "trace.jsonl"
        argv = [*RUNS[name], "--quiet"]
        if argv[0] == "mission":
            argv += ["--output", tmp]
            trace = Path(tmp) / "trace.jsonl"
        else:
            argv += ["--trace", str(trace)]
        with wire_tap() as result, contextlib.redirect_stdout(io.StringIO()):
            result["exit_code"] = main(argv)
        lines = trace.read_text(encoding="utf-8").splitlines()
    body = "\n".join(lines[1:]).encode()
    result["trace_records"] = len(lines) - 1
    result["trace_sha256"] = hashlib.sha256(body).hexdigest()
    return result


LAB_DEMO = "lab-demo"
"""The xdist group of the tests that read the one lab mission ``lab_demo`` runs."""


@dataclass(frozen=True)
class LabDemo:
    """``pirate-bt demo``'s run (``tests/conftest.py``'s ``lab_demo`` fixture): its
    output folder, its lab mission's digests (as :func:`record` gives them) and what it
    printed."""

    folder: Path
    digests: dict[str, Any]
    printed: str


def record_demo(folder: Path) -> tuple[dict[str, Any], str]:
    """Run ``pirate-bt demo --quiet --output FOLDER`` in this process: the digests of its
    lab mission, as :func:`record` gives them, and what it printed.

    The demo's mission is ``RUNS["lab-mission"]``, byte for byte (the golden test
    compares it with that run's recorded digests): the suite runs the lab mission once
    for both the golden test and the demo's (``tests/conftest.py``, ``lab_demo``).
    """
    import py_trees

    from pirate_bt.cli import main

    py_trees.blackboard.Blackboard.clear()
    printed = io.StringIO()
    with wire_tap() as result, contextlib.redirect_stdout(printed):
        result["exit_code"] = main(["demo", "--quiet", "--output", str(folder)])
    lines = (folder / "trace.jsonl").read_text(encoding="utf-8").splitlines()
    body = "\n".join(lines[1:]).encode()
    result["trace_records"] = len(lines) - 1
    result["trace_sha256"] = hashlib.sha256(body).hexdigest()
    return result, printed.getvalue()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--write", action="store_true", help=f"write {GOLDEN.name}")
    parser.add_argument("names", nargs="*", choices=[*RUNS, []], help="runs (default all)")
    args = parser.parse_args()
    results = {name: record(name) for name in args.names or RUNS}
    text = json.dumps(results, indent=2, sort_keys=True) + "\n"
    if args.write:
        GOLDEN.write_text(text, encoding="utf-8")
    print(text, end="")


if __name__ == "__main__":
    main()
