"""The stops of a run's end are in its trace: the end record's ``commands``.

A failed or interrupted run stops its running nodes and puts the robot in its safe
state after its last tick; no tick records those verdicts, so a trace used to end
without the stop that left the robot safe. A successful run sends nothing after its
last tick, and its end record is as before (the golden runs pin that byte for byte).
"""

from __future__ import annotations

from pathlib import Path

import pirate_bt
from pirate_bt.trace.records import trace_schema
from pirate_bt.trace.text import format_summary, summarise

STRAIGHT = Path(__file__).parents[1] / "trees" / "straight.yaml"


def test_a_failed_run_records_the_stop_after_its_last_tick(tmp_path: Path) -> None:
    path = tmp_path / "run.jsonl"
    result = pirate_bt.simulate_tree(
        STRAIGHT, params={"distance": "1 m"}, faults="link_loss@5s", trace=path
    )
    assert not result.succeeded
    trace = pirate_bt.read_trace(path)
    assert trace.end is not None
    final = trace.end["commands"]
    stops = [c for c in final if c["command"] == "stop()" and c["source"] == "supervisor"]
    assert stops and stops[0]["detail"].startswith("safe state: link_silent: nothing heard")
    assert ["bend_1_drive", "velocity", 0.0] in stops[0]["sent"]  # the drives it stopped
    end = trace_schema()["$defs"]["end"]["properties"]
    assert end["commands"]["items"] == {"$ref": "#/$defs/command"}  # the schema says so
    lines = format_summary(summarise(trace), trace.structure)
    at = lines.index("after the last tick:")
    # the drive at work stopped by the run's end (its terminate: the run ends at the
    # tick after the supervisor's stop, 672c15d), then the supervisor's safe state
    after = [line for line in lines[at + 1 :] if line.startswith("  ")]
    assert after[0].startswith("  stop() [tree] pass")
    assert any(
        line.startswith("  stop() [supervisor] pass: safe state: link_silent") for line in after
    )


def test_a_successful_run_has_nothing_after_its_last_tick(tmp_path: Path) -> None:
    path = tmp_path / "run.jsonl"
    result = pirate_bt.simulate_tree(STRAIGHT, params={"distance": "0.2 m"}, trace=path)
    assert result.succeeded
    end = pirate_bt.read_trace(path).end
    assert end is not None and "commands" not in end
