"""Faster must not mean different: recorded runs give the same wire bytes and trace.

The digests in ``tests/data/golden/runs.json`` were recorded before the tick-cost
work of issue 15 (the runner ticking the active path only, the trace reading only
where the tree moved, the cheaper simulator and link steps); see
``tests/golden_runs.py`` for what is recorded and how to regenerate it.
"""

from __future__ import annotations

import json

import pytest

from tests.golden_runs import GOLDEN, LAB_DEMO, RUNS, record

EXPECTED = json.loads(GOLDEN.read_text(encoding="utf-8"))


# The lab mission (about 5 s) among the slow tests, started first: the demo's run,
# shared with the demo's own test (conftest.py's lab_demo), which is that mission byte
# for byte; `python -m tests.golden_runs --write` records it as `pirate-bt mission`.
@pytest.mark.parametrize(
    "name",
    [
        pytest.param(n, marks=[pytest.mark.slow, pytest.mark.xdist_group(LAB_DEMO)])
        if n == "lab-mission"
        else n
        for n in sorted(RUNS)
    ],
)
def test_a_recorded_run_is_byte_for_byte_the_same(
    name: str, request: pytest.FixtureRequest
) -> None:
    got = request.getfixturevalue("lab_demo").digests if name == "lab-mission" else record(name)
    want = EXPECTED[name]
    assert got["exit_code"] == want["exit_code"] == 0
    # Sizes first: a differing size says more than a differing digest.
    assert (got["wire_out_bytes"], got["wire_in_bytes"]) == (
        want["wire_out_bytes"],
        want["wire_in_bytes"],
    )
    assert got["trace_records"] == want["trace_records"]
    assert got == want
