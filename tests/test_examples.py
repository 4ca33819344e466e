"""Every script in ``examples/`` runs as a user would run it, and shows what it should.

Each example runs as ``python examples/NAME.py`` from the repository root, in its
own process, with no arguments (``real_port.py`` then starts the simulator as a
separate process). The assertions are on the lines a user reads, so the examples
the docs point at cannot rot. Each example runs once per worker: the two tests that read
``mission_table.py``'s output read the same run (one xdist group keeps them together).
"""

from __future__ import annotations

import functools
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
EXAMPLES = REPO / "examples"

# the real-time group (tests/conftest.py): real_port.py runs a simulator on TCP
# against the wall clock; the rest share the once-built examples on one worker
pytestmark = pytest.mark.xdist_group("real-time")

# example -> lines (regular expressions, searched line by line) its output must hold
EXPECTED: dict[str, list[str]] = {
    "tree_on_simulator.py": [
        r"^status: failure$",
        r"^why: +stall: bend_3_drive draws [\d.]+ A",
        r"^where: +bend/pass bend/confirm enter/front into turn$",
        r"^bend: FAILURE - stall: bend_3_drive .* at bend/pass bend/confirm enter/front into turn",
        r"^left in its safe state: True$",
    ],
    "mission_table.py": [
        r"^PAB +kind +outcome +start s +end s +why$",
        r"^03 bend right .* bend +failure .* stall: bend_3_drive",
        r"^04 inspect .* not run",
        r"^mission: failure - stall: bend_3_drive",
        r"^failed at: mission/route/03 bend right .*/front into turn$",
        r"^counters: \d+ violations, \d+ damage, \d+ refusals, \d+ clips, 1 safe states",
    ],
    "python_built_tree.py": [
        r"^refused: examples/python_built_tree\.py:\d+:1: too hard: torque: 50 N\*m is above",
        r"^my straight: SUCCESS - tree succeeded",
        r"^our condition said: roll -?[\d.]+ deg$",
        r"^counters: 0 violations, 0 refusals, \d+ clips$",
    ],
    "trace_query.py": [
        r"^failure: ticks 1 to \d+",
        r"^the run's why: stall: bend_3_drive",
        r"clamp rear half: tick \d+$",
        r"^  front into turn: tick \d+ \([\d.]+ s\) -> FAILURE$",
        r"^  front into turn at tick 120: RUNNING$",
        r"^first failure: tick \d+, bend/pass bend/confirm enter/front into turn$",
        r"^  feedback: stall: bend_3_drive",
    ],
    "random_explorer.py": [
        r"^seed 0: success after 4 steps, ways taken \{'tee-1': 'branch'\}$",
        r"^  why: navigator 'RandomExplorer' is done after 4 steps$",
        r"^  ended at [\d.]+ m \(service-1-up\)$",
    ],
    "seeded_runs.py": [
        r"^\d+/20 runs succeeded \(\d+%; 95 % interval \d+% to \d+%\)$",
    ],
    "real_port.py": [
        r"^simulator serving on socket://127\.0\.0\.1:\d+$",
        r"^straight: SUCCESS - .*\(robot at socket://127\.0\.0\.1:\d+;",
        r"^link: \d+ retries, \d+ CRC errors$",
    ],
}


@functools.cache
def run_example(name: str) -> subprocess.CompletedProcess[str]:
    env = {k: v for k, v in os.environ.items() if k != "PIRATE_PORT"}
    return subprocess.run(
        [sys.executable, str(Path("examples") / name)],
        cwd=REPO,
        env=env,
        capture_output=True,
        text=True,
        timeout=90,
    )


def test_every_example_is_checked_and_documented() -> None:
    found = sorted(p.name for p in EXAMPLES.glob("*.py"))
    assert found == sorted(EXPECTED), "add the new example's expected lines to EXPECTED"
    api = (REPO / "docs" / "api.md").read_text(encoding="utf-8")
    missing = [name for name in found if f"examples/{name}" not in api]
    assert not missing, f"docs/api.md does not list {missing}"


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_example_runs_and_shows_what_it_should(name: str) -> None:
    proc = run_example(name)
    assert proc.returncode == 0, f"{name} exited {proc.returncode}\n{proc.stdout}\n{proc.stderr}"
    lines = proc.stdout.splitlines()
    for pattern in EXPECTED[name]:
        assert any(re.search(pattern, line) for line in lines), (
            f"{name}: no line matches {pattern!r}\n--- stdout:\n{proc.stdout}"
        )


def test_mission_table_lists_every_pab_of_the_plan() -> None:
    import pirate_bt

    plan = pirate_bt.plan_route(REPO / "scenarios" / "bend-right.route")
    proc = run_example("mission_table.py")
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    labels = [pab.label(i) for i, pab in enumerate(plan.pabs, start=1)]
    assert len(labels) >= 3
    for label in labels:
        assert any(line.startswith(label) for line in lines), f"{label!r} not in the table"
