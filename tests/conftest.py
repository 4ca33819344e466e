"""Shared test set-up: hypothesis profiles and paths to the repository's data.

Profiles: ``ci`` (default; bounded and deterministic) and ``long`` for soak runs
(``HYPOTHESIS_PROFILE=long``).
"""

from __future__ import annotations

import os
import signal
from collections.abc import Iterator
from pathlib import Path

import pytest
from hypothesis import HealthCheck, settings

settings.register_profile(
    "ci",
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.too_slow],
    print_blob=True,
)
settings.register_profile("long", deadline=None, max_examples=20_000)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))

REPO = Path(__file__).resolve().parent.parent


@pytest.fixture
def repo() -> Path:
    """The repository root."""
    return REPO


# -- running in parallel (pytest-xdist) --------------------------------------------------
#
# pyproject.toml's addopts say ``-n auto --dist loadgroup``. ``-n auto`` asks
# pytest_xdist_auto_num_workers below: one worker per CPU for a whole-suite run (2
# on the 2-core machine), none (in process, no start-up cost) when the command line
# names test files or tests. ``-n N`` on the command line overrides it.

REAL_TIME = "real-time"
"""The xdist group of the tests whose bridge runs against the wall clock.

The AVR firmware in simavr (the harness takes most of a core, beside the Python
boards and a host process) and the conformance suite's simulated bridge on a pty
(its watchdog trips when the test falls silent for 250 ms). Two at once on two cores
starve each other: one worker runs them all, one after another, at a higher priority
(_real_time_ahead), while the other runs the rest.
"""

_SIMAVR_MODULES = {"test_firmware_sim.py", "test_firmware_sim_summary.py"}
_REAL_TIME_BRIDGES = {"firmware-simavr", "sim-pty"}


@pytest.hookimpl(optionalhook=True)  # a hook of pytest-xdist's
def pytest_xdist_auto_num_workers(config: pytest.Config) -> int:
    names_tests = any("::" in arg or arg.endswith(".py") for arg in config.invocation_params.args)
    if names_tests:
        return 0
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


def _runs_in_real_time(item: pytest.Item) -> bool:
    if item.path.name in _SIMAVR_MODULES:
        return True
    if item.path.name == "test_firmware_build.py" and "simavr" in item.name:
        return True
    callspec = getattr(item, "callspec", None)
    return callspec is not None and callspec.params.get("bridge") in _REAL_TIME_BRIDGES


def pytest_itemcollected(item: pytest.Item) -> None:
    """The real-time tests into one xdist group, as each is collected.

    Before any ``pytest_collection_modifyitems``, where pytest-xdist reads the
    ``xdist_group`` marks (on each worker, with ``--dist loadgroup``) to write the
    group's name into the test ids its scheduler groups by: a mark added by a later
    hook (the ``trylast`` one below did it until 2026-11-29) comes too late.
    """
    if _runs_in_real_time(item):
        item.add_marker(pytest.mark.xdist_group(REAL_TIME))


def _group_names(item: pytest.Item) -> str:
    """The test's xdist groups as pytest-xdist joins them ('' for none)."""
    names = {
        str(mark.args[0] if mark.args else mark.kwargs.get("name", "default"))
        for mark in item.iter_markers("xdist_group")
    }
    return "_".join(sorted(names))


def _keep_groups_together(items: list[pytest.Item]) -> None:
    """Give each grouped test the ``@group`` suffix pytest-xdist's scheduler groups by.

    pytest-xdist 3.8 writes it into ``item._nodeid``, which pytest 9.2 no longer reads
    (a node's id is a structured ``_id`` there): the suffix never reached the
    scheduler, and every xdist group (the real-time tests, the Groot2 oracle, ROS 2,
    ...) was spread over both workers like ungrouped tests (pytest-xdist issue 1386).
    Until pytest-xdist writes it again, it is written here, once, the same way.
    """
    try:
        from _pytest.nodeid import NodeId
    except ImportError:  # an older pytest: pytest-xdist's own suffix works there
        return
    for item in items:
        names = _group_names(item)
        if names and hasattr(item, "_id") and not item.nodeid.endswith(f"@{names}"):
            item._id = NodeId.parse(f"{item.nodeid}@{names}")


@pytest.hookimpl(trylast=True)  # after any shuffling plugin (pytest-randomly), and xdist
def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """The ``slow`` tests first; xdist groups kept together (:func:`_keep_groups_together`).

    Long tests first (a stable sort, the rest keep their order) so that no long test
    starts last on one worker while the other has nothing left to do.
    """
    if getattr(config.option, "loadgroup", False):  # set on the workers of --dist loadgroup
        _keep_groups_together(items)
    items.sort(key=lambda item: item.get_closest_marker("slow") is None)


@pytest.fixture(autouse=True)
def _real_time_ahead(request: pytest.FixtureRequest) -> Iterator[None]:
    """The real-time tests ahead of the CPU-bound tests on the other worker.

    The test's process and everything it starts meanwhile (the harness, the Python
    boards, the host) run at nice -10 where that is allowed (root, as in CI), and the
    worker goes back to its own priority afterwards. The link's limits (500 ms of
    bridge silence, from the firmware's 250 ms watchdog) are real time: a bridge or a
    host starved by a busy core would trip them for reasons that have nothing to do
    with what is tested.
    """
    group = request.node.get_closest_marker("xdist_group")
    if group is None or group.args[:1] != (REAL_TIME,):
        yield
        return
    try:
        os.nice(-10)
    except OSError:
        yield
        return
    try:
        yield
    finally:
        os.nice(10)


@pytest.fixture(autouse=True)
def _ctrl_c_left_as_found(request: pytest.FixtureRequest) -> Iterator[None]:
    """Fail a test that leaves Ctrl-C (SIGINT) handled otherwise than it found it.

    A disposition of SIG_IGN is inherited by every process started afterwards, so one
    test that ignores SIGINT in the test process would make the Ctrl-C tests of any
    later test (in random order) silently fail to interrupt their subprocess. (The run
    itself may start with SIGINT ignored: see ctrl_c_reaches_children.)
    """
    before = signal.getsignal(signal.SIGINT)
    yield
    after = signal.getsignal(signal.SIGINT)
    if after is not before:
        signal.signal(signal.SIGINT, before)
        pytest.fail(f"{request.node.nodeid} left SIGINT handled by {after!r} (was {before!r})")


@pytest.fixture
def ctrl_c_reaches_children() -> Iterator[None]:
    """The processes the test starts take Ctrl-C (SIGINT) as from a terminal: for the Ctrl-C tests.

    A shell without job control starts a background command (``pytest ... &`` in a
    script, or a long run left going from a tool) with SIGINT ignored, and an ignored
    signal stays ignored through fork and exec. Python installs its KeyboardInterrupt
    handler only where SIGINT was at its default, so in such a run every subprocess a
    test starts ignores the Ctrl-C the test sends it (a campaign runs to the end, a
    worker waits on), whatever the order of the tests. A handled signal goes back to
    its default action on exec: SIGINT handled here for the test's duration (as in a
    foreground run) gives the test's subprocesses the default, as a terminal's would
    have. The run's own disposition is restored afterwards.
    """
    before = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        yield
    finally:
        if before is not None:
            signal.signal(signal.SIGINT, before)
