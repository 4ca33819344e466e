"""The command line's contract under hostile input and interruption (DESIGN.md).

Each error is one line on stderr with an exit code of DESIGN.md and no traceback
(unless ``--debug``); an output that cannot be written is refused before work is
done, or fails whole (no half-written file); a trace that cannot be written fails the
run with the robot left safe; SIGTERM stops a run as Ctrl-C does.
"""

from __future__ import annotations

import gzip
import logging
import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import py_trees
import pytest

from pirate_bt.cli import main
from pirate_bt.clock import SimClock
from pirate_bt.runner import Runner, StopReason
from pirate_bt.trace import read_trace

REPO = Path(__file__).resolve().parent.parent
STRAIGHT = str(REPO / "trees" / "straight.yaml")
PY_CLI = [sys.executable, "-m", "pirate_bt"]
RUN = ["run", STRAIGHT, "--param", "distance=0.1m", "--quiet"]


@pytest.fixture(scope="module")
def trace_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("contract") / "run.jsonl"
    assert main([*RUN, "--trace", str(path)]) == 0
    return path


def one_error_line(err: str) -> str:
    lines = [line for line in err.splitlines() if line.startswith("pirate-bt:")]
    assert len(lines) == 1, err
    assert "Traceback" not in err and "internal error" not in err, err
    return lines[0]


def no_tracebacks_logged(caplog: pytest.LogCaptureFixture) -> bool:
    return not [
        r
        for r in caplog.records
        if r.levelno >= logging.WARNING and (r.exc_info or "Traceback" in r.getMessage())
    ]


def leftovers(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name.endswith((".tmp", ".part")))


# -- options ----------------------------------------------------------------------------


def test_a_bad_log_level_is_bad_input(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["--log", "link=loud", "schema", "tree"]) == 2
    assert "bad --log 'link=loud'" in one_error_line(capsys.readouterr().err)


def test_debug_after_the_verb_shows_the_traceback(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    import pirate_bt.cli.validate as validate

    def boom(*_: object, **__: object) -> None:
        raise RuntimeError("kaboom")

    monkeypatch.setattr(validate, "validate_file", boom)
    with pytest.raises(RuntimeError, match="kaboom"):  # an internal error goes out whole
        main(["validate", "x.yaml", "--debug"])
    # after a verb's action too; an input error keeps its exit code (it re-raised: exit 1)
    assert main(["trace", "summary", "no-such.jsonl", "--debug"]) == 2
    said = capsys.readouterr().err
    assert "Traceback (most recent call last)" in said and "cannot read trace" in said


def test_sim_refuses_a_port_or_duration_that_cannot_be(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["sim", "lab", "--tcp", "99999"]) == 2
    assert "--tcp 99999: a port is 0 to 65535" in one_error_line(capsys.readouterr().err)
    assert main(["sim", "lab", "--duration", "-1"]) == 2
    assert "--duration must be a positive" in one_error_line(capsys.readouterr().err)


def test_rates_that_would_never_end_a_run_are_refused(capsys: pytest.CaptureFixture[str]) -> None:
    # 1e-9 Hz (a tick every 31 years, the simulator stepping through all of it) or 1e9 Hz
    # (6e11 ticks) never ended; the same limits, with a time limit that keeps the old
    # behaviour short: a tick after the time limit, 1000 ticks more than a robot can use.
    for rate, max_time in (("0.1 Hz", "2 s"), ("2 kHz", "0.5 s")):
        assert main([*RUN, "--rate", rate, "--max-time", max_time]) == 2
        assert "the tick rate must be at most 1000 Hz" in one_error_line(capsys.readouterr().err)
    assert main(["teleop", "--keys", "w", "--rate", "nan"]) == 2
    assert "--rate must be positive" in one_error_line(capsys.readouterr().err)


def test_a_mission_refuses_a_rate_or_trace_it_could_never_use(
    capsys: pytest.CaptureFixture[str],
) -> None:
    # the mission verb hung on 1e-9 Hz (no --max-time: the plan's limit is the bound)
    # and opened the simulator before refusing a trace it cannot write
    mission = ["mission", "straight.route", "--quiet"]
    assert main([*mission, "--rate", "1e-9 Hz"]) == 2
    assert "a tick must come within the plan's time limit" in one_error_line(
        capsys.readouterr().err
    )
    assert main([*mission, "--trace", "run.txt"]) == 2
    assert "run.txt: unknown trace format" in one_error_line(capsys.readouterr().err)


def test_a_parameter_given_twice_with_two_values_is_refused(
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert main([*RUN, "--param", "distance=0.5m"]) == 2  # the last one silently won
    assert "--param distance: given twice ('0.1m', then '0.5m')" in one_error_line(
        capsys.readouterr().err
    )


# -- outputs ----------------------------------------------------------------------------


def test_outputs_that_are_folders_are_one_line_exit_2(
    trace_file: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "run.jsonl").mkdir()
    (tmp_path / "tree.svg").mkdir()
    (tmp_path / "plot.png").mkdir()
    (tmp_path / "surveyed.yaml").mkdir()
    assert main([*RUN, "--trace", str(tmp_path / "run.jsonl")]) == 2
    assert "--trace" in one_error_line(capsys.readouterr().err)
    assert main(["render", STRAIGHT, "-o", str(tmp_path / "tree.svg")]) == 2
    assert "tree.svg' is a folder; name a file" in one_error_line(capsys.readouterr().err)
    assert main(["trace", "plot", str(trace_file), "-o", str(tmp_path / "plot.png")]) == 2
    assert "-o: " in (line := one_error_line(capsys.readouterr().err))
    assert "plot.png' is a folder; name a file" in line
    # refused before the survey (exit 2), not after it (exit 1, the survey lost)
    assert main(["survey", "--sim", "straight", "-o", str(tmp_path / "surveyed.yaml")]) == 2
    assert "is a folder; name a file" in one_error_line(capsys.readouterr().err)
    assert leftovers(tmp_path) == []


def test_a_trace_path_under_a_file_is_refused_before_connecting(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], caplog: pytest.LogCaptureFixture
) -> None:
    (tmp_path / "file").write_text("")
    assert main([*RUN, "--trace", str(tmp_path / "file" / "run.jsonl")]) == 2
    assert "is not a folder (on the way to 'run.jsonl')" in one_error_line(capsys.readouterr().err)
    assert not [r for r in caplog.records if "safe state" in r.getMessage()]  # nothing opened


@pytest.mark.skipif(not Path("/proc/self").is_dir(), reason="needs /proc")
def test_a_diagram_that_cannot_be_written_is_not_a_success(
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert main(["render", STRAIGHT, "-o", "/proc/no-such/tree.svg"]) == 2
    # refused before any work: /proc takes no file (the check writes and removes one)
    err = one_error_line(capsys.readouterr().err)
    assert "-o: cannot write /proc/no-such/tree.svg: /proc takes no file" in err
    assert main(["robot", "--draw", "/proc/robot.svg"]) == 2
    out, err = capsys.readouterr()
    assert "--draw: cannot write /proc/robot.svg: /proc takes no file" in one_error_line(err)
    assert out == ""  # nothing printed before the refusal (the board table came first)


def test_pictures_need_a_suffix_they_can_be_written_in(
    trace_file: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["trace", "plot", str(trace_file), "-o", str(tmp_path / "plot")]) == 2
    assert "cannot plot to a name without a suffix" in one_error_line(capsys.readouterr().err)
    assert main(["trace", "plot", str(trace_file), "-o", str(tmp_path / "plot.jsonl")]) == 2
    assert "cannot plot to .jsonl" in one_error_line(capsys.readouterr().err)
    assert main(["robot", "--draw", str(tmp_path / "robot")]) == 2
    assert "use .dot, .svg or .png" in one_error_line(capsys.readouterr().err)
    assert sorted(p.name for p in tmp_path.iterdir()) == []


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="needs /dev/full")
def test_a_full_disk_fails_a_picture_and_keeps_the_old_one(
    trace_file: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    (tmp_path / "full.png").symlink_to("/dev/full")
    assert main(["trace", "plot", str(trace_file), "-o", str(tmp_path / "full.png")]) == 2
    assert "full.png: No space left on device" in one_error_line(capsys.readouterr().err)
    # An existing picture is replaced whole or not at all.
    old = tmp_path / "tree.svg"
    old.write_text("old picture")
    import pirate_bt.render.files as files

    def refuse(*_: object) -> None:
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(files.os, "replace", refuse)
    assert main(["render", STRAIGHT, "-o", str(old)]) == 2
    monkeypatch.undo()
    assert "tree.svg': No space left on device" in one_error_line(capsys.readouterr().err)
    assert old.read_text() == "old picture"
    assert leftovers(tmp_path) == []


# -- a trace that cannot be written -------------------------------------------------------


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="needs /dev/full")
def test_a_trace_onto_a_device_is_refused_before_the_run(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "full.jsonl"
    path.symlink_to("/dev/full")  # it failed the run only after the robot had moved
    assert main([*RUN, "--trace", str(path)]) == 2
    line = one_error_line(capsys.readouterr().err)
    assert "is not a regular file (a pipe or a device)" in line and "ticks" not in line


@pytest.mark.skipif(not hasattr(signal, "SIGXFSZ"), reason="needs file size limits")
@pytest.mark.parametrize("suffix", [".jsonl", ".jsonl.gz"])
def test_a_trace_that_fails_mid_run_fails_the_run_and_leaves_the_robot_safe(
    suffix: str, tmp_path: Path
) -> None:
    import resource

    def file_size_limit() -> None:  # a disk that fills during the run, in the child only
        resource.setrlimit(resource.RLIMIT_FSIZE, (4096, 4096))
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)

    path = tmp_path / f"full{suffix}"
    done = subprocess.run(
        [*PY_CLI, *RUN[:2], "--param", "distance=0.3 m", "--quiet", "--trace", str(path)],
        preexec_fn=file_size_limit,
        # no bytecode written under the limit: a cut .pyc of a module changed since its
        # last import would break every later import of it in the shared tree
        env={**os.environ, "PYTHONDONTWRITEBYTECODE": "1"},
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 1, done  # .jsonl.gz failed only at close: was 0
    errors = [x for x in done.stderr.splitlines() if x.startswith("pirate-bt:")]
    assert len(errors) == 1, done.stderr
    assert "FAILURE" in errors[0] and f"full{suffix}" in errors[0]
    assert "File too large" in errors[0]
    assert "safe state" in done.stderr and "Traceback" not in done.stderr


def test_a_finish_hook_that_fails_fails_the_run_safely() -> None:
    calls: list[str] = []
    runner = Runner(
        py_trees.behaviours.Success("done"),
        clock=SimClock(),
        safe_state=lambda: calls.append("safe"),
    )

    def lose_the_trace(_result: object) -> None:
        raise RuntimeError("the trace writer failed")

    runner.add_finish(lose_the_trace)
    result = runner.run()
    assert (result.outcome, result.reason) == ("failure", StopReason.EXCEPTION)
    assert "the trace writer failed" in result.message and result.safe_state_called
    assert calls == ["safe"]


def test_a_second_ctrl_c_does_not_cut_the_safe_stop_short() -> None:
    calls: list[str] = []

    def safe_state() -> None:
        calls.append("safe")
        if len(calls) == 1:
            raise KeyboardInterrupt

    runner = Runner(py_trees.behaviours.Failure("no"), clock=SimClock(), safe_state=safe_state)
    assert runner.run().safe_state_called
    assert calls == ["safe", "safe"]


# -- traces that cannot be read -------------------------------------------------------------


def test_damaged_traces_are_one_line_naming_file_and_line(
    trace_file: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    data = trace_file.read_bytes()
    cut_header = tmp_path / "cut-header.jsonl"
    cut_header.write_bytes(data[:200])
    assert main(["trace", "summary", str(cut_header)]) == 2
    assert f"{cut_header}:1:1: the header record is cut off" in one_error_line(
        capsys.readouterr().err
    )
    not_gzip = tmp_path / "plain.jsonl.gz"
    not_gzip.write_bytes(data)
    assert main(["trace", "show", str(not_gzip)]) == 2
    # a JSON Lines trace named .jsonl.gz is told the name to give it (cb351af)
    assert f"{not_gzip}: a JSON Lines trace, not gzip-compressed: name it plain.jsonl" in (
        one_error_line(capsys.readouterr().err)
    )
    packed = gzip.compress(data)
    damaged = tmp_path / "damaged.jsonl.gz"
    damaged.write_bytes(packed[:-8] + bytes(b ^ 0xFF for b in packed[-8:-4]) + packed[-4:])
    assert main(["trace", "summary", str(damaged)]) == 2  # was read as a cut-off run
    assert f"{damaged}:" in one_error_line(capsys.readouterr().err)
    cut = tmp_path / "cut.jsonl.gz"
    cut.write_bytes(packed[: len(packed) // 2])  # a killed writer: read up to the cut
    assert main(["trace", "summary", str(cut)]) == 0
    assert "incomplete" in capsys.readouterr().out


def test_render_takes_an_mcap_trace_as_a_trace(
    trace_file: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    pytest.importorskip("mcap")
    mcap = tmp_path / "run.mcap"
    assert main(["trace", "export", str(trace_file), "-o", str(mcap)]) == 0
    assert main(["render", str(mcap), "--tick", "3", "-o", str(tmp_path / "t.dot")]) == 0
    assert (tmp_path / "t.dot").read_text().startswith("digraph")  # was: "not YAML text"
    capsys.readouterr()


def test_a_format_reader_that_stumbles_is_bad_input(
    trace_file: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    pytest.importorskip("mcap")
    garbage = tmp_path / "garbage.mcap"
    garbage.write_bytes(b"garbage")
    assert main(["trace", "summary", str(garbage)]) == 2
    assert f"{garbage}: not a readable MCAP file (cut off or damaged: 7 bytes)" in (
        one_error_line(capsys.readouterr().err)
    )
    # cut inside its first chunk: said so, with its size (it said 'not an MCAP file: ')
    whole = tmp_path / "whole.mcap"
    assert main(["trace", "export", str(trace_file), "-o", str(whole)]) == 0
    capsys.readouterr()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(whole.read_bytes()[:200])
    assert main(["trace", "summary", str(cut)]) == 2
    assert f"{cut}: not a readable MCAP file (cut off or damaged: 200 bytes)" in (
        one_error_line(capsys.readouterr().err)
    )


# -- interruption -----------------------------------------------------------------------------


def test_interrupts_outside_a_run_exit_130_or_143(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    import pirate_bt.cli.schema as schema

    def terminated(_args: object) -> int:
        os.kill(os.getpid(), signal.SIGTERM)  # raises in this thread, from main's handler
        raise AssertionError("SIGTERM did not interrupt")

    def unhandled(_signum: int, _frame: object) -> None:
        raise AssertionError("main left SIGTERM to the handler it found")

    monkeypatch.setattr(schema, "run", terminated)
    before = signal.signal(signal.SIGTERM, unhandled)
    try:
        assert main(["schema", "tree"]) == 143
        assert signal.getsignal(signal.SIGTERM) is unhandled  # left as found
    finally:
        signal.signal(signal.SIGTERM, before)
    assert "terminated (SIGTERM)" in one_error_line(capsys.readouterr().err)

    def interrupted(_args: object) -> int:
        raise KeyboardInterrupt

    monkeypatch.setattr(schema, "run", interrupted)
    assert main(["schema", "tree"]) == 130


@pytest.mark.usefixtures("ctrl_c_reaches_children")
def test_sigint_and_sigterm_stop_a_run_safely_with_its_trace_whole(tmp_path: Path) -> None:
    signalled_runs = {"INT": tmp_path / "int.jsonl", "TERM": tmp_path / "term.jsonl"}
    procs: dict[str, subprocess.Popen[str]] = {}
    for name, path in signalled_runs.items():
        procs[name] = subprocess.Popen(
            [sys.executable, "-m", "pirate_bt", "run", STRAIGHT, "--param", "distance=5m",
             "--realtime", "--quiet", "--trace", str(path)],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )  # fmt: skip
    try:
        deadline = time.monotonic() + 20
        for name, path in signalled_runs.items():
            while not (path.exists() and path.read_bytes().count(b'"type":"tick"') >= 3):
                assert procs[name].poll() is None and time.monotonic() < deadline
                time.sleep(0.02)
            procs[name].send_signal(getattr(signal, f"SIG{name}"))
        done = {name: proc.communicate(timeout=20) for name, proc in procs.items()}
    finally:
        for proc in procs.values():
            if proc.poll() is None:
                proc.kill()
    for name, path in signalled_runs.items():
        err = done[name][1]
        assert procs[name].returncode == 1, err  # a run that did not succeed, robot safe
        why = "Ctrl-C" if name == "INT" else "SIGTERM"
        assert f"interrupted ({why})" in one_error_line(err)
        assert "safe state" in err
        trace = read_trace(path)
        assert trace.outcome == "interrupted" and trace.why == f"interrupted ({why})"


def test_an_interrupt_while_the_command_loads_is_one_line(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    # the command's module was imported before the interrupt handling began: a Ctrl-C
    # in the first 0.3 s printed a traceback, a SIGTERM killed the process silently
    import importlib

    from pirate_bt.cli import Terminated

    real = importlib.import_module

    def interrupted(name: str, *args: Any, **kwargs: Any) -> Any:
        if name == "pirate_bt.cli.validate":
            raise KeyboardInterrupt
        if name == "pirate_bt.cli.render":
            raise Terminated
        return real(name, *args, **kwargs)

    monkeypatch.setattr(importlib, "import_module", interrupted)
    assert main(["validate", STRAIGHT]) == 130
    assert one_error_line(capsys.readouterr().err) == "pirate-bt: interrupted"
    assert main(["render", STRAIGHT, "-o", "x.svg"]) == 143
    assert one_error_line(capsys.readouterr().err) == "pirate-bt: terminated (SIGTERM)"


def test_a_terminated_campaign_exits_143_and_keeps_its_rows(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    import pirate_bt.campaign as campaign
    from pirate_bt.cli import Terminated

    def terminated(*args: Any, echo: Any, **kwargs: Any) -> Any:
        echo("case 1 of 2")  # the cases have started
        raise Terminated

    monkeypatch.setattr(campaign, "run_campaign", terminated)
    spec = Path(__file__).parents[1] / "scenarios" / "campaigns" / "pab-drop.campaign.yaml"
    assert main(["campaign", str(spec), "--output", str(tmp_path / "out"), "--quiet"]) == 143
    err = one_error_line(capsys.readouterr().err)
    assert err.startswith("pirate-bt: campaign terminated (SIGTERM);") and "--resume" in err


@pytest.mark.parametrize("spec", ["link=warn", "link=notset", "link=fatal", "link=", "linkdebug"])
def test_a_log_level_not_in_the_docs_is_bad_input(
    spec: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["--log", spec, "validate", STRAIGHT]) == 2
    assert "with a level of debug, info, warning, error, critical" in one_error_line(
        capsys.readouterr().err
    )


def test_validate_knows_an_mcap_trace_by_its_suffix(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    import pirate_bt

    trace = tmp_path / "run.mcap"
    pirate_bt.simulate_tree("straight", params={"distance": "0.05 m"}, trace=trace)
    assert main(["validate", str(trace)]) == 0  # was "binary file, not YAML text"
    capsys.readouterr()
    assert main(["validate", str(tmp_path / "nope.jsonl")]) == 2
    err = capsys.readouterr().err
    assert len(err.splitlines()) == 1 and err.count("nope.jsonl") == 1, err  # named once


@pytest.mark.parametrize(
    ("argv", "words"),
    [
        (["run", STRAIGHT, "--max-time"], "pirate-bt run: argument --max-time: expected one"),
        (["nope"], "pirate-bt: argument COMMAND: invalid choice: 'nope'"),
        (["network", "perturb"], "pirate-bt network perturb: the following arguments are"),
        (["run", STRAIGHT, "--no-such-option"], "pirate-bt run: unrecognized arguments"),
    ],
)
def test_a_usage_error_is_one_line(
    argv: list[str], words: str, capsys: pytest.CaptureFixture[str]
) -> None:
    # argparse printed its usage block first: eight lines for one mistake
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert len(err.splitlines()) == 1, err
    assert words in err and "--help'" in err, err


def test_demo_refuses_bad_input_before_printing_or_writing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # it printed the robot's board table (and drew robot.svg) before failing
    assert main(["demo", "--output", "/proc/xx", "-q"]) == 2
    out, err = capsys.readouterr()
    assert out == "" and "--output: cannot write /proc/xx/report.md" in one_error_line(err)
    bad = tmp_path / "bad.route"
    bad.write_text("network lab\nforward 1 km\n", encoding="utf-8")
    assert main(["demo", "--route", str(bad), "--output", str(tmp_path / "out"), "-q"]) == 2
    out, err = capsys.readouterr()
    assert out == "" and "bad.route:2:1: 'forward 1 km' does not fit" in one_error_line(err)
    assert not (tmp_path / "out").exists()
