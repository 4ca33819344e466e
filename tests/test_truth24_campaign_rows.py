"""Session 24: a campaign's rows say where a mission or navigation ended, by belief and truth.

With a truth that differs from the map (a `maps` entry, an `as_built` variant), a row
said why a case failed but not where the robot believed it was nor where it truly was:
a reader of `results.jsonl` or `results.csv` could not tell a stop where belief and
pipe had parted by a metre from one where they agreed. Route and navigator rows now
carry `belief_m` (along the map) and `truth_m` (the simulator's front tip, counted on
the map from the same segment), and a `--resume` after a crash keeps them.
"""

from __future__ import annotations

import csv
import json
from pathlib import Path

from pirate_bt.campaign.run import run_campaign

MAP = """schema_version: 1
name: drawn
diameter: 63 mm
segments:
  - {{id: before, type: straight, length: {before} m}}
  - {{id: bend, type: bend, direction: right, radius: 90 mm}}
  - {{id: after, type: straight, length: 2 m}}
"""
ROUTE = "network drawn\n\nforward 1 m\nat the bend turn right\ninspect to the end\n"


def test_rows_say_belief_and_truth_and_a_resume_keeps_them(tmp_path: Path) -> None:
    (tmp_path / "drawn.yaml").write_text(MAP.format(before=2), encoding="utf-8")
    (tmp_path / "built.yaml").write_text(MAP.format(before=1), encoding="utf-8")  # 50 % short
    (tmp_path / "r.route").write_text(ROUTE, encoding="utf-8")
    spec = {
        "name": "truth",
        "runs": [
            {"name": "mission", "route": "r.route", "network": "drawn.yaml"},
            {
                "name": "goal",
                "navigator": "goal",
                "network": "drawn.yaml",
                "params": {"segment": "after"},
            },
        ],
        "maps": ["built.yaml"],
        "max_time": "120 s",
    }
    spec_file = tmp_path / "truth.campaign.yaml"
    spec_file.write_text(json.dumps(spec), encoding="utf-8")
    out = tmp_path / "out"
    first = run_campaign(spec_file, workers=1, output=out)
    for row in first.rows:
        assert row["outcome"] == "failed-safe", row
        # the first cause: the pipe before the bend is shorter than drawn, by a metre
        said = "belief and map disagree: the pipe blocked the robot at 1.00 m"
        assert row["reason"].startswith(said)
        assert "the map's next turn, 'bend', is drawn 1.00 m further on" in row["reason"]
        # the robot believes it is 1 m along 'before'; truly it is at the bend (2 m on the map)
        assert abs(row["belief_m"] - 1.0) < 0.05 and abs(row["truth_m"] - 2.0) < 0.05, row
    with (out / "results.csv").open(encoding="utf-8") as stream:
        table = list(csv.DictReader(stream))
    assert [round(float(r["truth_m"]) - float(r["belief_m"]), 1) for r in table] == [1.0, 1.0]

    # a crash after the first row: the second is lost, and its line was cut off
    results = out / "results.jsonl"
    kept = results.read_text(encoding="utf-8").splitlines()[0]
    results.write_text(kept + "\n" + '{"id": "0000', encoding="utf-8")
    again = run_campaign(spec_file, workers=1, output=out, resume=True)
    assert [r["id"] for r in again.rows] == [r["id"] for r in first.rows]
    for old, new in zip(first.rows, again.rows, strict=True):
        assert (new["belief_m"], new["truth_m"], new["reason"]) == (
            old["belief_m"],
            old["truth_m"],
            old["reason"],
        )
