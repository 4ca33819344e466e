"""The suite's own sorting of tests by how they use time (tests/conftest.py).

With a worker more than cores, a test that waits on the wall clock must be in the
real-time group and a test run behind the others (nice 19) must not wait on it. A
renamed module would silently leave its group, and a wall-clock test added to a
simulated-clock module would starve behind the others: both are caught here.
"""

from __future__ import annotations

import re
from pathlib import Path

import conftest
import pytest

TESTS = Path(__file__).resolve().parent

# What a test that waits on the wall clock uses: a pty or TCP bridge, a run at real
# time, a wall clock, a sleep, a subprocess (timed against real time).
WALL_CLOCK = re.compile(
    r"openpty|--tcp|realtime=True|\"--realtime\"|import socket|WallClock|time\.sleep|subprocess"
)

GROUPS = {
    "simulated clock": conftest._SIMULATED_CLOCK_MODULES,
    "wall clock": conftest._WALL_CLOCK_MODULES,
    "simavr": conftest._SIMAVR_MODULES,
}


@pytest.mark.parametrize("group", list(GROUPS))
def test_every_module_named_in_a_group_exists(group: str) -> None:
    missing = sorted(name for name in GROUPS[group] if not (TESTS / name).is_file())
    assert not missing, f"{group}: no such test module {missing}"


def test_no_module_is_in_two_groups() -> None:
    behind = conftest._SIMULATED_CLOCK_MODULES
    ahead = conftest._WALL_CLOCK_MODULES | conftest._SIMAVR_MODULES
    assert not behind & ahead


@pytest.mark.parametrize("name", sorted(conftest._SIMULATED_CLOCK_MODULES))
def test_a_module_run_behind_the_others_never_waits_on_the_wall_clock(name: str) -> None:
    text = (TESTS / name).read_text()
    found = sorted({m.group(0) for m in WALL_CLOCK.finditer(text)})
    assert not found, f"{name} is run at nice 19 but uses {found}: move it out of the group"


def test_the_wall_clock_pattern_finds_what_it_looks_for() -> None:
    # the check above must be able to fail: the real-time modules it would refuse
    assert WALL_CLOCK.search((TESTS / "test_link_session.py").read_text())
    assert WALL_CLOCK.search((TESTS / "test_sim_server.py").read_text())


def test_the_groups_are_the_suites_own() -> None:
    assert Path(conftest.__file__).resolve() == TESTS / "conftest.py"
