"""Small leftovers the twentieth session's helpers reported outside their scopes: a
reason a node gives the supervisor itself, of any length, and faults given as an
endless iterator to the public ``split_faults``."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

import pirate_bt
from pirate_bt.api import split_faults
from pirate_bt.api.fault_text import MAX_FAULTS
from pirate_bt.errors import InputError


def test_a_safe_state_reason_a_node_gives_itself_is_cut() -> None:
    # the runner cut its own messages (b9dc9d4), but a node calling the supervisor
    # with a 100 kB reason had it kept whole: in safe_state_reason, the safety log and
    # every verdict the trace writes after it
    with pirate_bt.connect("sim:straight") as robot:
        robot.supervisor.safe_state("the pipe is blocked: " + "z" * 100_000)
        reason = robot.supervisor.safe_state_reason or ""
    assert reason.startswith("the pipe is blocked: zzz")
    assert len(reason) <= 1000 and reason.endswith(" more characters)")


def test_an_estop_reason_a_node_gives_itself_is_cut() -> None:
    with pirate_bt.connect("sim:straight") as robot:
        robot.supervisor.estop("smoke: " + "s" * 50_000)
        reason = robot.supervisor.estop_reason or ""
    assert reason.startswith("smoke: sss") and len(reason) <= 1000


def test_split_faults_refuses_an_endless_iterator_without_reading_it_all() -> None:
    # the API's runs read a one-shot iterator once and at most MAX_FAULTS + 1 items
    # (31a9627); split_faults, public too, read all of it before counting: an endless
    # one (itertools.repeat) hung for ever
    read = 0

    def faults() -> Iterator[str]:
        nonlocal read
        while read < 100_000:  # long enough to tell, short enough never to hang a test
            read += 1
            yield "drop=0.01"

    with pytest.raises(InputError, match=f"at most {MAX_FAULTS} faults"):
        split_faults(faults())
    assert read <= MAX_FAULTS + 2
