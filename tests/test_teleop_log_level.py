"""``pirate-bt teleop`` called in-process (``pirate_bt.cli.main``) sets the protective
layer's log back as it found it: it left it at ERROR, and every later run in that
process lost its 'safe state' warnings (a test of the full-disk trace failed after it)."""

from __future__ import annotations

import logging

import pytest

from pirate_bt.cli import main


def test_teleop_leaves_the_safety_log_as_it_found_it(capsys: pytest.CaptureFixture[str]) -> None:
    log = logging.getLogger("pirate_bt.safety")
    before = log.level
    assert main(["teleop", "--keys", "q"]) == 0, capsys.readouterr().err
    assert log.level == before
