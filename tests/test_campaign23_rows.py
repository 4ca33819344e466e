"""Session 23: a results file edited by hand whose row holds a value no campaign writes
where the report reads it (an as-built scale that is no number, a run that is no name,
a seed that is no seed number) is skipped with a warning naming its line, as the rows
with a bad counter or rate were: `pirate-bt campaign report` ended in an internal error
(*ValueError: could not convert string to float: 'x'*), or showed the value as a group
(*{'a': 1} drop=0.1 ...*) and a reason (*1 × {'a': 1}*)."""

from __future__ import annotations

import json
import logging
from pathlib import Path
from typing import Any

import pytest

from pirate_bt.cli import main

GOOD = {
    "id": "000000-aaaa",
    "index": 0,
    "run": "r",
    "seed": 0,
    "drop": 0.1,
    "corrupt": 0,
    "dup": 0,
    "outcome": "success",
    "reason": "fine",
    "sim_time_s": 1.0,
}


@pytest.mark.parametrize(
    ("bad", "said"),
    [
        # was: internal error, ValueError: could not convert string to float: 'x'
        ({"as_built": 1, "as_built_scale": "x"}, "as_built_scale 'x' is not a number"),
        ({"as_built": "3"}, "as_built '3' is not a count"),
        ({"seed": [1]}, "seed [1] is not a count"),
        # was: the group '{'a': 1} drop=0.1 corrupt=0 dup=0'
        ({"run": {"a": 1}}, "run {'a': 1} is not text"),
        ({"robot": 123}, "robot 123 is not text"),
        # was: '1 × {'a': 1}' among the reasons, '`['x']`' among the failing nodes
        ({"reason": {"a": 1}, "outcome": "failed-safe"}, "reason {'a': 1} is not text"),
        ({"failing_node": ["x"], "outcome": "failed-safe"}, "failing_node ['x'] is not text"),
        ({"blind": "yes"}, "blind 'yes' is not true or false"),
    ],
    ids=lambda v: next(iter(v)) if isinstance(v, dict) else None,
)
def test_a_row_holding_what_no_campaign_writes_is_skipped(
    tmp_path: Path, caplog: pytest.LogCaptureFixture, bad: dict[str, Any], said: str
) -> None:
    results = tmp_path / "results.jsonl"
    row = {**GOOD, "id": "000001-bbbb", "index": 1, **bad}
    results.write_text(json.dumps(GOOD) + "\n" + json.dumps(row) + "\n")
    with caplog.at_level(logging.WARNING, logger="pirate_bt.campaign"):
        assert main(["campaign", "report", str(results)]) == 0
    assert f"results.jsonl:2: skipped a row that is not a case's result: {said}" in caplog.text
    report = (tmp_path / "report.md").read_text()
    assert "1 runs: 1 success" in report


def test_the_rows_a_campaign_writes_pass() -> None:
    from pirate_bt.campaign.case import error_record, row_problem

    case = {
        "id": "000003-cccc",
        "index": 3,
        "run": "r",
        "tree": None,
        "route": None,
        "network": None,
        "params": {},
        "robot": None,
        "map": None,
        "sim_faults": [],
        "drop": 0.0,
        "corrupt": 0.0,
        "dup": 0.0,
        "seed": 7,
        "navigator": "goal",
        "blind": False,
        "as_built": 2,
        "as_built_scale": 1.5,
    }
    assert row_problem(error_record(case, "timeout", "killed after its 1 s limit", 1.0)) is None
