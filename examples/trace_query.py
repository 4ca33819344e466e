"""Write a tick-by-tick trace of a run, read it back and ask it questions.

Run from the repository root: ``python examples/trace_query.py``.

Nodes are named by their path from the root, by a tail of it (``"front into
turn"``) or by a glob (``"*/clamp front half"``); statuses are ``SUCCESS``,
``FAILURE``, ``RUNNING``, ``INVALID``.
"""

import tempfile
from pathlib import Path

import pirate_bt

with tempfile.TemporaryDirectory() as folder:
    path = Path(folder) / "bend.jsonl"
    result = pirate_bt.simulate_tree(
        "bend",
        network="bend-right",
        params={"roll": "90 deg"},
        faults="motor_stall:bend_3_drive@5s+20s",
        trace=path,  # .jsonl, .jsonl.gz or .mcap
    )
    trace = pirate_bt.read_trace(path)

print(f"{trace.outcome}: ticks 1 to {trace.last_tick}, {trace.duration_s:.2f} s")
print(f"the run's why: {result.why}")
print(f"the trace's end record: {trace.why}")  # the runner's line; failures() has the cause

# When did each clamp first succeed? (the two after the turn never ran)
for node in trace.nodes("*/clamp * half"):
    tick = trace.first_tick(node, "SUCCESS")  # None: it never succeeded
    print(f"  {node}: {'never' if tick is None else f'tick {tick}'}")

# How did the node that went wrong change status, and what was it at tick 120?
turn = "front into turn"
for change in trace.statuses(turn):
    print(f"  {turn}: tick {change.tick} ({change.time_s:.2f} s) -> {change.status}")
print(f"  {turn} at tick 120: {trace.status_at(turn, 120)}")

# The first failure is where the run first went wrong; its feedback says why.
first = trace.failures()[0]
print(f"first failure: tick {first.tick}, {first.path}")
print(f"  feedback: {first.feedback}")
