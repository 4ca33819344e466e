"""Probe: a user reruns the benchmarks as docs/performance.md and their docstrings say.

`--help` prints what a script measures instead of starting a run of minutes, a wrong
argument is argparse's one-line error before anything runs, a missing optional
extra is one `skipped:` line (exit 0, as `bench_firmware.py` without simavr), and a
partial `bench_interop.py --only` run does not replace the page's three-row table.
No benchmark is run here: each command below stops before measuring anything.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
from bench_support import BENCHMARKS, load_benchmark

REPO = BENCHMARKS.parent


def _bench(
    name: str, *args: str, env: dict[str, str] | None = None
) -> subprocess.CompletedProcess[str]:
    """``.venv/bin/python benchmarks/bench_NAME.py ARGS`` from the repository, as documented."""
    return subprocess.run(
        [sys.executable, f"benchmarks/bench_{name}.py", *args],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=120,
        env=env,
    )


@pytest.mark.parametrize("name", ["foundation", "link", "pabs", "sim", "trace", "trees"])
def test_help_of_a_benchmark_without_options_prints_its_docstring_and_runs_nothing(
    name: str,
) -> None:
    done = _bench(name, "--help")
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith(f"usage: bench_{name}.py [-h]")
    assert f"benchmarks/bench_{name}.py" in done.stdout  # the docstring's Run: line
    assert "| " not in done.stdout  # no table: nothing was measured


@pytest.mark.parametrize(
    ("name", "args", "says"),
    [
        ("interop", ["0"], "argument pairs: '0': at least 1"),
        ("interop", ["--only", "xml"], "expected some of mcap,foxglove,jsonl"),
        ("interop", ["--tree"], "argument --tree: expected one argument"),
        ("ros2", ["--estop", "x"], "argument --estop: 'x' is not a whole number"),
        ("campaign", ["0"], "argument cases: '0': at least 1"),
        ("mission", ["0"], "argument runs: '0': at least 1"),
        ("btcpp", ["--runs", "0"], "argument --runs: '0': at least 1"),
        ("asbuilt", ["--scales", "1,x"], "argument --scales: 'x' is not a number"),
        ("survey", ["--networks", "nosuch"], "--networks: nosuch:1:1: no such network file"),
        ("plot", ["no-such-trace.jsonl"], "no-such-trace.jsonl: no such trace file"),
        ("scale", ["--only"], "argument --only: expected at least one argument"),
        ("groot2", ["--only"], "argument --only: expected at least one argument"),
    ],
)
def test_a_wrong_argument_is_one_line_before_anything_runs(
    name: str, args: list[str], says: str
) -> None:
    done = _bench(name, *args)
    assert done.returncode == 2
    assert "Traceback" not in done.stderr
    assert says in done.stderr.splitlines()[-1]
    assert "| " not in done.stdout


@pytest.mark.parametrize(
    ("name", "args", "module", "extra"),
    [
        ("groot2", ["--only", "scale"], "zmq", "groot2"),
        ("plot", [], "matplotlib", "plot"),
        ("ros2", ["1"], "zenoh", "ros2"),
        ("campaign", ["1", "1"], "distributed", "cluster"),
        ("interop", ["1", "--no-sizes", "--only", "mcap"], "mcap", "foxglove"),
    ],
)
def test_a_missing_optional_extra_is_one_skipped_line(
    tmp_path: Path, name: str, args: list[str], module: str, extra: str
) -> None:
    # the extra made unimportable, as where it was never installed
    (tmp_path / module).mkdir()
    (tmp_path / module / "__init__.py").write_text(
        f"raise ImportError('No module named {module}')\n"
    )
    env = {**os.environ, "PYTHONPATH": str(tmp_path)}
    done = _bench(name, *args, env=env)
    assert done.returncode == 0, done.stderr
    assert "Traceback" not in done.stderr
    last = done.stdout.splitlines()[-1]
    assert last.startswith(f"skipped: {module} cannot be imported")
    assert f"'.[{extra}]'" in last


def test_interop_only_some_rows_prints_them_but_keeps_the_pages_table(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    interop = load_benchmark("bench_interop")
    monkeypatch.setattr(interop, "_run", lambda extra: 4.0 if extra else 3.6)
    monkeypatch.setattr(interop, "_run_with_client", lambda: (4.1, 100))
    monkeypatch.setenv("PIRATE_BENCH_RESULTS", str(tmp_path))
    monkeypatch.setattr(interop, "NAMES", ["--trace RUN.jsonl"])
    interop.overhead(1)
    assert not list(tmp_path.iterdir())  # one row of three: not published
    monkeypatch.setattr(interop, "NAMES", list(interop.OVERHEAD_LABELS))
    interop.overhead(1)
    assert [p.name for p in tmp_path.iterdir()] == ["interop-overhead.json"]


def test_make_bench_refuses_set_for_a_benchmark_that_does_not_exist(
    capsys: pytest.CaptureFixture[str],
) -> None:
    run_all = load_benchmark("run_all")
    with pytest.raises(SystemExit) as stop:  # a typo: not interop run with its defaults
        run_all.main(["--list", "--set", "introp=5 --no-sizes"])
    assert stop.value.code == 2
    assert "--set: no benchmark introp" in capsys.readouterr().err.splitlines()[-1]
    run_all.main(["--list", "--set", "interop=5 --no-sizes"])
    assert "benchmarks/bench_interop.py 5 --no-sizes" in capsys.readouterr().out.splitlines()


def test_bench_firmware_without_avr_gcc_skips_as_the_other_firmware_benchmarks() -> None:
    # make bench only warns when it may not install the toolchain; a failing script
    # would stop it with nothing written, where bench_firmware_sim.py skips
    env = {**os.environ, "PATH": str(REPO / "no-such-bin")}
    done = _bench("firmware", "--soak", "0", env=env)
    assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines()[-1].startswith("skipped: avr-gcc is missing")
