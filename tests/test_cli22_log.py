"""``--log SUBSYSTEM=LEVEL`` is repeatable, one level per subsystem: two levels for one
are refused, as any option given twice with two values is."""

from __future__ import annotations

import logging

import pytest

from pirate_bt.cli import main


def test_two_levels_for_one_subsystem_are_refused(capsys: pytest.CaptureFixture[str]) -> None:
    """Before: ``--log link=debug --log pirate_bt.link=info`` set the link's logger to
    info, the last given, without a word, exit 0."""
    link = logging.getLogger("pirate_bt.link")
    before = link.level
    argv = ["--log", "link=debug", "--log", "pirate_bt.link=info", "schema", "tree"]
    try:
        assert main(argv) == 2
    finally:
        link.setLevel(before)
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err.splitlines() == [
        "pirate-bt: --log: 'link=debug', then 'pirate_bt.link=info': two levels for one"
        " subsystem; give one"
    ]
