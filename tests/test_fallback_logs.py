"""A primitive that fails as one way of a fallback is the tree's flow, not a warning.

A survey at the end of a straight pipe probes up, down, right and left (a selector in
``trees/probe-turn.yaml``) and found the end: a success, which printed four WARNING
lines ('front in up failed: blocked ...') before its summary. The same failure outside
a fallback still warns. (A PAB's failure is one way of its recovery fallback: the
supervisor's safe-state warning names it.)
"""

from __future__ import annotations

import logging

import pytest

import pirate_bt

LOGGER = "pirate_bt.behaviours.primitives"  # primitive.py logs as its package did


def _failures(caplog: pytest.LogCaptureFixture) -> list[logging.LogRecord]:
    return [r for r in caplog.records if r.name == LOGGER and " failed: " in r.getMessage()]


def test_probes_that_fail_inside_a_fallback_are_logged_as_information(
    caplog: pytest.LogCaptureFixture,
) -> None:
    caplog.set_level(logging.INFO, LOGGER)
    result = pirate_bt.survey(sim="straight")
    assert result.succeeded, result.why
    failed = _failures(caplog)
    assert any(r.getMessage().startswith("front in up failed: blocked") for r in failed)
    assert all(r.levelno == logging.INFO for r in failed)


def test_a_failure_outside_a_fallback_still_warns(caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.INFO, LOGGER)
    # the front half clamps before its module is clear: refused, in a plain sequence
    clamp = {"type": "clamp", "half": "front", "torque": "0.7 N*m"}
    result = pirate_bt.simulate_tree({"root": {"type": "sequence", "children": [clamp]}})
    assert not result.succeeded and "front_not_clear" in result.why
    failed = _failures(caplog)
    assert failed and all(r.levelno == logging.WARNING for r in failed)
