"""Shared test set-up: hypothesis profiles and paths to the repository's data.

Profiles: ``ci`` (default; bounded and deterministic) and ``long`` for soak runs
(``HYPOTHESIS_PROFILE=long``).
"""

from __future__ import annotations

import os
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

REAL_TIME_SIMAVR = "simavr"
"""The xdist group of the tests that run the AVR firmware in simavr in real time.

Each runs the harness (most of a core), the Python boards and a host process against
the wall clock; two at once on two cores starve each other. One worker runs them
all, one after another, while the other runs the rest.
"""

_SIMAVR_MODULES = {"test_firmware_sim.py", "test_firmware_sim_summary.py"}


def pytest_xdist_auto_num_workers(config: pytest.Config) -> int:
    names_tests = any("::" in arg or arg.endswith(".py") for arg in config.invocation_params.args)
    if names_tests:
        return 0
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


def _runs_simavr(item: pytest.Item) -> bool:
    if item.path.name in _SIMAVR_MODULES:
        return True
    if item.path.name == "test_firmware_build.py" and "simavr" in item.name:
        return True
    callspec = getattr(item, "callspec", None)
    return callspec is not None and callspec.params.get("bridge") == "firmware-simavr"


@pytest.hookimpl(trylast=True)  # after any shuffling plugin (pytest-randomly)
def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """The simavr tests into one xdist group; the ``slow`` tests first.

    Long tests first (a stable sort, the rest keep their order) so that no long test
    starts last on one worker while the other has nothing left to do.
    """
    for item in items:
        if _runs_simavr(item):
            item.add_marker(pytest.mark.xdist_group(REAL_TIME_SIMAVR))
    items.sort(key=lambda item: item.get_closest_marker("slow") is None)
