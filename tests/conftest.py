"""Shared test set-up: hypothesis profiles and paths to the repository's data.

Profiles: ``ci`` (default; bounded and deterministic) and ``long`` for soak runs
(``HYPOTHESIS_PROFILE=long``).
"""

from __future__ import annotations

import contextlib
import functools
import os
import signal
from collections.abc import Iterator
from pathlib import Path
from typing import Any

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


@pytest.fixture(scope="session")
def lab_demo(tmp_path_factory: pytest.TempPathFactory) -> Any:
    """The demo, run once per worker for every test that reads it (the golden lab
    mission and the demo's own test, both in the ``lab-demo`` xdist group so that one
    worker runs them): the lab mission is the suite's longest single run."""
    from tests.golden_runs import LAB_DEMO, LabDemo, record_demo

    folder = tmp_path_factory.mktemp(LAB_DEMO) / "demo"
    digests, printed = record_demo(folder)
    return LabDemo(folder, digests, printed)


# -- running in parallel (pytest-xdist) --------------------------------------------------
#
# pyproject.toml's addopts say ``-n auto --dist loadgroup``. ``-n auto`` asks
# pytest_xdist_auto_num_workers below: one worker per CPU for a whole-suite run, and
# one more where priorities can be set (3 on the 2-core machine, as root), none (in
# process, no start-up cost) when the command line names test files or tests. ``-n N``
# on the command line overrides it.

REAL_TIME = "real-time"
"""The xdist group of the tests whose bridge runs against the wall clock.

The AVR firmware in simavr (the harness takes most of a core, beside the Python
boards and a host process) and the conformance suite's simulated bridge on a pty
(its watchdog trips when the test falls silent for 250 ms). Two at once on two cores
starve each other: one worker runs them all, one after another, at a higher priority
(_real_time_ahead), while the others run the rest.
"""

_SIMAVR_MODULES = {"test_firmware_sim.py", "test_firmware_sim_summary.py"}
_WALL_CLOCK_MODULES = {
    "test_link_session_resets.py",  # a simulated bridge on a pty
    "test_link_transport.py",
    "test_link_lost_exit.py",
    "test_sim_server.py",  # the simulator on TCP and a pty
    "test_sim22_backlog.py",  # the same, a host that stops reading
    "test_fw22_pty_reset.py",  # a host on the simulator's pty, its bridge's watchdog
    "test_console.py",  # the operator console on a live simulator
    "test_foxglove_live.py",  # live clients, runs at real time
    "test_mcap_process.py",
    "test_groot2.py",  # ZeroMQ clients, silences timed on the wall clock
    "test_interop_peers.py",
    "test_probe8_interop.py",
    "test_probe16_interop_live.py",  # a live Groot2 server, wall-clock waits
}
"""Modules whose tests wait on the wall clock (a bridge's silence limit, a live client's
timeouts): in the real-time group too, so that none of them shares the CPU with another
(a pty link lost its bridge once, 0.5 s silent, with three workers and a busy loop
beside the suite). A new module of that kind belongs here, or in the group by its own
``pytestmark = pytest.mark.xdist_group("real-time")`` (the examples, the Groot2 oracle,
ROS 2).

Not ``test_link_session.py``: its pty test under injected faults (drops, corruption,
reordering; a request may give up after 4 tries and the bridge's watchdog trip) failed
twice in nine suites inside the group, never at a worker's own priority."""
_REAL_TIME_BRIDGES = {"firmware-simavr", "sim-pty"}


_SIMULATED_CLOCK_MODULES = {
    "test_mission_asbuilt.py",
    "test_pabs.py",
    "test_pabs_backwards.py",
    "test_firmware_chain.py",
    "test_safety_sim_property.py",
    "test_safety_property.py",
    "test_probe_tee.py",
    "test_golden_runs.py",
    "test_link_long_session.py",
    "test_probe8_nav.py",
    "test_survey_bend_angles.py",
    "test_survey_probe_fixes.py",
    "test_truth_not_map.py",
    "test_tee_edge.py",
}
"""The modules whose tests are CPU-bound on a simulated clock only: no wall-clock
limit, no socket, no pty, no subprocess timed against real time (the whole chain in
simavr runs in virtual time). With a worker more than cores (:func:`_cores`) they run
behind every other test (:func:`_simulated_clock_behind`). A module may be added here
only when none of its tests waits on the wall clock."""

_BEHIND_NICE = 19
_REAL_TIME_NICE = -20


def _cores() -> int:
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


@functools.cache
def _may_raise_priority() -> bool:
    """Whether this process may raise its priority (root with ``CAP_SYS_NICE``, as in
    CI): tried once, one step up and back, rather than assumed from the user id."""
    if not hasattr(os, "setpriority"):
        return False
    try:
        now = os.getpriority(os.PRIO_PROCESS, 0)
        os.setpriority(os.PRIO_PROCESS, 0, now - 1)
        os.setpriority(os.PRIO_PROCESS, 0, now)
    except OSError:
        return False
    return True


@contextlib.contextmanager
def _at_nice(value: int) -> Iterator[None]:
    """This process at nice ``value`` for the block (with the threads and processes it
    starts meanwhile), back to its own afterwards; as it was where that is refused."""
    before = os.getpriority(os.PRIO_PROCESS, 0)
    try:
        os.setpriority(os.PRIO_PROCESS, 0, value)
    except OSError:
        yield
        return
    try:
        yield
    finally:
        os.setpriority(os.PRIO_PROCESS, 0, before)


@pytest.hookimpl(optionalhook=True)  # a hook of pytest-xdist's
def pytest_xdist_auto_num_workers(config: pytest.Config) -> int:
    names_tests = any("::" in arg or arg.endswith(".py") for arg in config.invocation_params.args)
    if names_tests:
        return 0
    cores = _cores()
    # One worker more than cores where the simulated-clock tests can be put behind the
    # others: the real-time worker waits on the wall clock most of the time, and its core
    # would otherwise sit idle. Every worker keeps its normal priority; only a test of
    # _SIMULATED_CLOCK_MODULES runs at nice 19, so a test that waits on the wall clock
    # never has less than a fair share of a core, wherever it runs.
    return cores + 1 if cores >= 2 and _may_raise_priority() else cores


def _runs_in_real_time(item: pytest.Item) -> bool:
    if item.path.name in _SIMAVR_MODULES or item.path.name in _WALL_CLOCK_MODULES:
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
    """The real-time tests ahead of the CPU-bound tests on the other workers.

    The test's process and everything it starts meanwhile (the harness, the Python
    boards, the host) run at nice -20 where that is allowed (root, as in CI), and the
    worker goes back to its own priority afterwards. At -20 a real-time process sharing
    a core with two busy workers at 0 still has 98 % of it (at -10 it had 82 %, and a
    simavr PAB lost its link once in two runs with a third worker and a busy loop
    beside the suite). The link's limits (500 ms of
    bridge silence, from the firmware's 250 ms watchdog) are real time: a bridge or a
    host starved by a busy core would trip them for reasons that have nothing to do
    with what is tested.
    """
    group = request.node.get_closest_marker("xdist_group")
    if group is None or group.args[:1] != (REAL_TIME,) or not _may_raise_priority():
        yield
        return
    with _at_nice(_REAL_TIME_NICE):
        yield


@pytest.fixture(autouse=True)
def _simulated_clock_behind(request: pytest.FixtureRequest) -> Iterator[None]:
    """A test on the simulated clock only runs at nice 19 when there are more workers
    than cores: it takes the core the real-time tests leave idle, and gives way to
    every test that waits on the wall clock (and to what those tests start)."""
    workers = int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "0"))
    if (
        request.node.path.name not in _SIMULATED_CLOCK_MODULES
        or workers <= _cores()
        or not _may_raise_priority()
    ):
        yield
        return
    with _at_nice(_BEHIND_NICE):
        yield


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


@pytest.fixture(autouse=True)
def ctrl_c_reaches_children() -> Iterator[None]:
    """The processes every test starts take Ctrl-C (SIGINT) as from a terminal.

    A shell without job control starts a background command (``pytest ... &`` in a
    script, or a long run left going from a tool) with SIGINT ignored, and an ignored
    signal stays ignored through fork and exec. Python installs its KeyboardInterrupt
    handler only where SIGINT was at its default, so in such a run every subprocess a
    test starts ignores the Ctrl-C the test sends it (a campaign runs to the end, a
    worker waits on), whatever the order of the tests. A handled signal goes back to
    its default action on exec: SIGINT handled here for the test's duration (as in a
    foreground run) gives the test's subprocesses the default, as a terminal's would
    have. The run's own disposition is restored afterwards.

    For every test (autouse), not only those that name it: until 2026-12-01 two Ctrl-C
    tests whose subprocess sends itself the signal, or whose campaign is sent it, did
    not name it, and failed in a suite started in the background (their subprocess ran
    to the end: *status success*, *exit 0 == 130*).
    """
    before = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        yield
    finally:
        if before is not None:
            signal.signal(signal.SIGINT, before)
