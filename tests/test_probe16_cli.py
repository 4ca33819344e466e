"""Probe 16, the command-line contract as a shell user and a script see it.

A closed pipe (``| head -1``), a full device (``> /dev/full``), standard error
whose reader went away: each is the command's exit code and at most one line,
never ``Exception ignored`` and exit 120, a traceback, or exit 0 for nothing written.
"""

from __future__ import annotations

import io
import os
import subprocess
import sys
from pathlib import Path

import pytest

from pirate_bt.cli import main

ROOT = Path(__file__).resolve().parents[1]


def _pirate_bt(args: list[str], stdout: int) -> subprocess.CompletedProcess[str]:
    env = {k: v for k, v in os.environ.items() if k != "PYTHONUNBUFFERED"}  # as a shell has
    return subprocess.run(
        [sys.executable, "-m", "pirate_bt", *args],
        stdout=stdout,
        stderr=subprocess.PIPE,
        text=True,
        cwd=ROOT,
        env=env,
        timeout=60,
        check=False,
    )


def _closed_pipe(args: list[str]) -> subprocess.CompletedProcess[str]:
    """``pirate-bt ARGS | head -0``: the reader is gone before anything is written."""
    read, write = os.pipe()
    os.close(read)
    try:
        return _pirate_bt(args, write)
    finally:
        os.close(write)


@pytest.mark.parametrize(
    ("args", "code"),
    [
        (["robot"], 0),  # was "Exception ignored ... BrokenPipeError", exit 120
        (["--version"], 0),  # was a traceback from argparse, exit 1
        (["validate", "trees/bend.yaml", "nosuch"], 2),  # the verdict, not 120
    ],
)
def test_a_reader_that_went_away_leaves_the_exit_code_and_no_noise(
    args: list[str], code: int
) -> None:
    done = _closed_pipe(args)
    assert done.returncode == code, done.stderr
    assert "Exception ignored" not in done.stderr
    assert "Traceback" not in done.stderr
    assert len(done.stderr.splitlines()) == (0 if code == 0 else 1), done.stderr


@pytest.mark.skipif(not Path("/dev/full").exists(), reason="no /dev/full here")
@pytest.mark.parametrize(
    "args",
    [
        ["robot", "header", "-o", "-"],  # was exit 0 and nothing said: the header lost
        ["--help"],  # was "Exception ignored", exit 120
    ],
)
def test_standard_output_on_a_full_device_is_one_line_and_exit_2(args: list[str]) -> None:
    with open("/dev/full", "w") as full:
        done = _pirate_bt(args, full.fileno())
    assert done.returncode == 2, done.stderr
    assert done.stderr.splitlines() == ["pirate-bt: standard output: No space left on device"]


class _FullStream(io.StringIO):
    """A stream on a full device: every write fails as a full disk's does."""

    def write(self, text: str) -> int:
        raise OSError(28, "No space left on device")


class _GoneStream(io.StringIO):
    """A pipe whose reader went away."""

    def write(self, text: str) -> int:
        raise BrokenPipeError(32, "Broken pipe")


def test_a_write_to_a_full_standard_output_names_it(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setattr(sys, "stdout", _FullStream())
    assert main(["schema", "hardware"]) == 2
    # was "pirate-bt: No space left on device": no name for what could not be written
    assert capsys.readouterr().err == "pirate-bt: standard output: No space left on device\n"


def test_standard_error_gone_does_not_turn_a_failure_into_success(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """``pirate-bt validate nosuch 2>&1 | head -0`` exited 0: the broken pipe on the
    error line was taken for a closed standard output."""
    monkeypatch.setattr(sys, "stderr", _GoneStream())
    assert main(["validate", "nosuch"]) == 2


def test_teleop_with_standard_input_closed_says_it_needs_a_terminal(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """``pirate-bt teleop <&-`` was 'internal error: AttributeError: 'NoneType' object
    has no attribute 'isatty'', exit 1: no terminal, as with ``< /dev/null``."""
    monkeypatch.setattr(sys, "stdin", None)
    assert main(["teleop"]) == 2
    err = capsys.readouterr().err
    assert err == "pirate-bt: the console needs a terminal; use --keys KEYS in scripts\n"


@pytest.fixture(scope="module")
def trace_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("probe16") / "run.jsonl"
    args = ["run", "straight", "--param", "distance=0.1m", "-q", "--max-time", "1s"]
    assert main([*args, "--trace", str(path)]) == 1  # a short run, ended by its time limit
    return path


def test_a_rosbag_folder_that_cannot_be_made_is_named_by_its_option(
    trace_file: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """'trace export -o run.jsonl/_bag' said 'out_dir: cannot write ...': the API's
    parameter, not the option the user typed."""
    capsys.readouterr()
    assert main(["trace", "export", str(trace_file), "-o", f"{trace_file}/_bag"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("pirate-bt: -o: ") and "is not a folder (on the way to '_bag')" in err
    assert len(err.splitlines()) == 1, err


@pytest.mark.parametrize("rate", ["20 Hz", "20Hz", "20"])
def test_teleop_takes_a_rate_as_run_takes_it(rate: str, capsys: pytest.CaptureFixture[str]) -> None:
    """'teleop --rate 20Hz' was 'invalid float value', while 'run --rate 20' asks for
    the unit: the same option, two syntaxes, each refusing the other's."""
    assert main(["teleop", "--keys", "q", "--rate", rate]) == 0, capsys.readouterr().err


@pytest.mark.parametrize(
    ("option", "message"),
    [
        (["--seed", "-1"], "--seed: give a whole number from 0 to 2**63 - 1, not -1"),
        (["--faults", "drop=2"], "link fault drop='2': a probability must lie in [0, 1]"),
        (["--faults", "motor_stall:nosuch@1s"], "fault motor_stall: unknown motor 'nosuch'"),
    ],
)
def test_mission_refuses_a_bad_seed_or_fault_before_printing_its_plan(
    option: list[str], message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    """'mission lab --seed -1' printed the whole plan (23 lines on stdout) and then
    refused the seed, exit 2: a script read a plan for a mission that never ran."""
    assert main(["mission", "lab", *option]) == 2
    out, err = capsys.readouterr()
    assert out == ""
    assert len(err.splitlines()) == 1 and message in err, err


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["navigate", "route", "--seed", "-1"], "--seed: give a whole number"),
        (["navigate", "route", "--max-time", "5"], "--max-time: '5' needs a unit"),
        (["navigate", "route", "--rate", "5"], "--rate: '5' needs a unit"),
        (["navigate", "route", "--deadline", "5"], "--deadline: '5' needs a unit"),
        (["navigate", "route", "--max-steps", "0"], "--max-steps: give 1 to 1,000,000, not 0"),
        (["survey", "-o", "s.yaml", "--search", "3"], "--search: '3' needs a unit"),
        (["survey", "-o", "s.yaml", "--radius=-5mm"], "--radius must be positive, not '-5mm'"),
        (["survey", "-o", "s.yaml", "--max-time", "5"], "--max-time: '5' needs a unit"),
        (["run", "straight", "--seed", "-1"], "--seed: give a whole number"),
        (["teleop", "--keys", "q", "--seed", "-1"], "--seed: give a whole number"),
    ],
)
def test_a_bad_option_is_named_as_typed_not_by_the_api_parameter(
    argv: list[str],
    message: str,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """'navigate route --max-time 5' said 'max_time: ...', '--deadline 5' 'deadline:
    ...', 'survey --search 3' 'explore: search: ...', 'run --seed -1' 'seed: ...': the
    API's parameter names, not the options the user typed."""
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"pirate-bt: {message}"), err
    assert len(err.splitlines()) == 1, err
    assert list(tmp_path.iterdir()) == []  # nothing written (survey's -o s.yaml)


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["demo", "-q", "--output", ""], "--output: empty; name a folder"),
        (["mission", "lab", "-q", "--output", ""], "--output: empty; name a folder"),
        (["mission", "lab", "--plan", "--sim", ""], "--sim: empty; name a network"),
        (["mission", "lab", "--plan", "--network", ""], "--network: empty; name a network"),
        (["run", "straight", "--sim", ""], "--sim: empty; name a network"),
        (["run", "straight", "--robot", ""], "--robot: empty; name a file"),
        (["teleop", "--keys", "q", "--sim", ""], "--sim: empty; name a network"),
        (["render", "bend", "-o", ""], "-o/--output: empty; name a file"),
    ],
)
def test_an_empty_value_is_refused_not_read_as_the_default_or_the_working_folder(
    argv: list[str],
    message: str,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """'demo --output "$DIR"' and 'mission lab --output "$DIR"' with DIR unset wrote
    their report, trace and pictures into the working folder; '--sim "$NET"' ran in
    the default network (straight, or the map), '--network ""' planned on the route's
    own: a wrong run, exit 0, nothing said."""
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    out, err = capsys.readouterr()
    assert (out, err) == ("", f"pirate-bt: {message}\n")
    assert list(tmp_path.iterdir()) == []


def test_options_where_empty_means_nothing_given_still_take_it(
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert main(["teleop", "--keys", ""]) == 0  # no keys: nothing played
    assert main(["mission", "lab", "--plan", "--faults", ""]) == 0  # no faults
    capsys.readouterr()


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["trace", "summary", ""], "TRACE: empty; name a file"),  # was '.: cannot read trace'
        (["network", "perturb", "--seed", "1", ""], "MAP: empty; name a network"),  # '.:1:1:'
        (["robot", "header", ""], "DESCRIPTION: empty; name a file"),  # '.:1:1: is a directory'
        (["sim", "", "--duration", "1"], "NETWORK: empty; name a network"),  # "it is a folder"
    ],
)
def test_an_empty_argument_is_named_not_read_as_the_working_folder(
    argv: list[str], message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(argv) == 2
    assert capsys.readouterr().err == f"pirate-bt: {message}\n"


@pytest.mark.parametrize(
    "argv",
    [
        ["robot", "header", "-o", "layout.h"],
        ["network", "perturb", "lab", "--seed", "1", "-o", "as-built.yaml"],
        ["export", "btcpp", "bend", "-o", "bend.xml"],
    ],
)
def test_the_path_written_is_on_standard_output_for_every_writer(
    argv: list[str],
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """'robot header -o F' and 'network ... -o F' said 'wrote F' on standard error,
    where export, import, render and trace say it on standard output: a script
    reading the path written got nothing from these two."""
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 0
    out, err = capsys.readouterr()
    assert (out, err) == (f"wrote {argv[-1]}\n", "")


def test_a_full_log_disk_does_not_stop_a_run_that_would_succeed(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    """'pirate-bt run ... 2>>run.log' with the log's disk full: the live view's
    failed write stopped the run mid-pipe, 'tree run ended without success: OSError:
    [Errno 28] No space left on device', exit 1, where it succeeds."""
    monkeypatch.setattr(sys, "stderr", _FullStream())
    trace = tmp_path / "run.jsonl"
    argv = ["run", "straight", "--param", "distance=0.1m", "--trace", str(trace)]
    assert main(argv) == 0
    assert '"outcome":"success"' in trace.read_text().replace(" ", "").splitlines()[-1]


def test_a_network_named_from_a_file_name_that_is_no_utf8_is_written(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """'network perturb $'\\xff.yaml' --seed 1' was 'internal error: UnicodeEncodeError:
    ... surrogates not allowed', exit 1: the header names the file as bytes \\xff."""
    source = os.fsdecode(bytes(tmp_path) + b"/\xff.yaml")
    Path(source).write_text((ROOT / "scenarios" / "lab.yaml").read_text(encoding="utf-8"))
    out = tmp_path / "as-built.yaml"
    assert main(["network", "perturb", source, "--seed", "1", "-o", str(out)]) == 0
    assert "\\xff.yaml" in out.read_text(encoding="utf-8").splitlines()[0]
    assert main(["validate", str(out)]) == 0
    capsys.readouterr()


@pytest.mark.parametrize(
    "argv",
    [
        ["survey", "-o", "s.yaml", "--name", "\udcff"],  # the whole survey ran first
        ["network", "add-tee", "lab", "run-b", "1m", "--id", "\udcfe", "-o", "n.yaml"],
    ],
)
def test_a_name_that_is_no_utf8_is_refused_before_any_work(
    argv: list[str],
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """'survey --name $'\\xff'' surveyed the whole network, then failed in 'internal
    error: ValidationError: ... unable to parse raw data as a unicode string' (four
    lines, exit 1) and wrote nothing."""
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert len(err.splitlines()) == 1 and "is not UTF-8 text" in err, err
    assert list(tmp_path.iterdir()) == []


def test_a_route_file_named_in_bytes_that_are_no_utf8_runs_as_a_mission(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # 'mission $'\xfc.route'' was refused with '<dict>:1:1: name: must not contain
    # control characters': the mission tree's name is the route's, made of the file name
    import os
    import shutil

    repo = Path(__file__).resolve().parent.parent
    odd = Path(os.fsdecode(bytes(tmp_path) + b"/\xfc\ta.route"))
    shutil.copy(repo / "scenarios" / "straight.route", odd)
    assert main(["mission", str(odd), "--quiet"]) == 0
    assert capsys.readouterr().out.startswith("mission \\xfc\\ta: SUCCESS")
