"""Small leftovers the twentieth session's helpers reported outside their scopes: a
reason a node gives the supervisor itself, of any length, and faults given as an
endless iterator to the public ``split_faults``."""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import py_trees
import pytest
from py_trees.common import Status

import pirate_bt
from pirate_bt import cli
from pirate_bt.api import split_faults
from pirate_bt.api.fault_text import MAX_FAULTS
from pirate_bt.clock import SimClock
from pirate_bt.errors import InputError
from pirate_bt.runner import RunInterrupted, Runner
from pirate_bt.units import parse_quantity


def test_a_safe_state_reason_a_node_gives_itself_is_cut() -> None:
    # the runner cut its own messages (b9dc9d4), but a node calling the supervisor
    # with a 100 kB reason had it kept whole: in safe_state_reason, the safety log and
    # every verdict the trace writes after it
    with pirate_bt.connect("sim:straight") as robot:
        robot.supervisor.safe_state("the pipe is blocked: " + "z" * 100_000 + " at the tee")
        reason = robot.supervisor.safe_state_reason or ""
    assert reason.startswith("the pipe is blocked: zzz") and reason.endswith("z at the tee")
    assert len(reason) <= 1000 and "characters)..." in reason


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


class _CtrlCWhenStopped(py_trees.behaviour.Behaviour):
    """Runs forever; Ctrl-C lands in its terminate() when the runner stops it."""

    def update(self) -> Status:
        return Status.RUNNING

    def terminate(self, new_status: Status) -> None:
        if new_status == Status.INVALID:
            raise KeyboardInterrupt


def _interrupted_run() -> RunInterrupted:
    runner = Runner(_CtrlCWhenStopped("watch"), clock=SimClock(), period_s=0.05, max_time_s=0.2)
    runner.safe_state = lambda: None
    with pytest.raises(RunInterrupted) as caught:
        runner.run()
    return caught.value


def test_a_ctrl_c_as_the_run_ends_goes_out_with_how_the_run_ended() -> None:
    exc = _interrupted_run()
    assert isinstance(exc, KeyboardInterrupt)  # it still stops the program
    assert isinstance(exc.__cause__, KeyboardInterrupt)
    assert exc.result.outcome == "failure" and exc.result.safe_state_called
    assert exc.result.message.startswith("time limit of 0.2 s reached")


def test_the_command_line_exits_1_on_a_ctrl_c_that_came_as_a_run_ended(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    # the robot moved and was left safe: 130 ('interrupted') says nothing moved
    exc = _interrupted_run()

    def _run(argv: object) -> int:
        raise exc

    monkeypatch.setattr(cli, "_main", _run)
    assert cli.main(["run", "x.yaml"]) == 1
    err = capsys.readouterr().err
    assert err.startswith("pirate-bt: FAILURE - time limit of 0.2 s reached")
    assert err.rstrip().endswith("the robot was left in its safe state")

    def _before(argv: object) -> int:
        raise KeyboardInterrupt

    monkeypatch.setattr(cli, "_main", _before)
    assert cli.main(["run", "x.yaml"]) == 130


@pytest.mark.parametrize("written", ["1,5 s", "0x10 s", "1_000 s", "0b11 s", "1 5 s", "1.2.3 s"])
def test_a_number_written_otherwise_is_said_to_be_one(written: str) -> None:
    # '1,5 s' said "unknown unit ',5'", '0x10 s' "unknown unit 'x10'": the unit was fine
    with pytest.raises(InputError) as caught:
        parse_quantity(written, "time")
    said = str(caught.value)
    assert "unknown unit" not in said
    assert "write the number in decimal digits with a dot (e.g. '1.5 s')" in said


@pytest.mark.parametrize(("written", "si"), [("2 1/s", 2.0), ("5s", 5.0), ("1e3 ms", 1.0)])
def test_units_after_a_number_still_read(written: str, si: float) -> None:
    dimension = "frequency" if "/" in written else "time"
    assert parse_quantity(written, dimension) == pytest.approx(si)


def test_the_simulator_s_ros2_node_declares_no_estop_it_cannot_hear(
    capsys: pytest.CaptureFixture[str],
) -> None:
    # pirate-bt sim --ros2 declared an e-stop subscription (ros2 topic info listed it)
    # though the simulator has no supervisor and dropped what it heard
    pytest.importorskip("zenoh")
    import argparse

    from pirate_bt.cli.run import open_ros2

    args = argparse.Namespace(ros2="tcp/127.0.0.1:7447", ros_domain_id=0, ros_namespace="/pirate")
    for estop in (False, True):
        node = open_ros2(args, estop=estop)
        try:
            assert (node.estop is None) is (not estop)
        finally:
            node.close()
    said = capsys.readouterr().err.splitlines()
    assert said[0].endswith("(no e-stop: nothing here to stop)")
    assert said[1].endswith("(e-stop: /pirate/estop)")


def test_a_campaign_report_draws_its_plot_whatever_mplbackend_names(tmp_path: Path) -> None:
    # the trace's plot imported matplotlib with MPLBACKEND set aside (705ec81); the
    # campaign's report imported it itself, and MPLBACKEND=bogus made that raise when it
    # came first in the process
    script = (
        "import sys\n"
        "from pathlib import Path\n"
        "from pirate_bt.campaign.report import _plots\n"
        "rows = [{'run': 'r', 'drop': d, 'outcome': 'success'} for d in (0.0, 0.1)]\n"
        "print([p.name for p in _plots(rows, Path(sys.argv[1]))])\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", script, str(tmp_path)],
        capture_output=True,
        text=True,
        env={**os.environ, "MPLBACKEND": "bogus"},
        timeout=300,
        check=False,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    assert "success_vs_drop.png" in done.stdout
    assert (tmp_path / "success_vs_drop.png").stat().st_size > 0


def test_debug_shows_the_traceback_and_keeps_the_exit_code(
    capsys: pytest.CaptureFixture[str],
) -> None:
    # --debug re-raised the error: every bad input (2) or link error (3) exited 1, which
    # says the tree failed and the robot was left safe
    argv = ["run", "straight", "--param", "distance=1m", "--param", "distance=2m"]
    assert cli.main(argv) == 2
    plain = capsys.readouterr().err
    assert cli.main(["--debug", *argv]) == 2
    debugged = capsys.readouterr().err
    assert "Traceback (most recent call last)" in debugged
    assert debugged.rstrip().endswith(plain.strip())
    assert cli.main([*argv, "--debug"]) == 2


@pytest.mark.skipif(not hasattr(os, "fork"), reason="needs fork")
def test_a_closed_trace_leaves_a_forked_child_s_descriptors_alone(tmp_path: Path) -> None:
    # a closed writer process stayed among what a fork lets go of: in the child its old
    # pipe's number, taken since by another pipe (a process pool's), was pointed at
    # /dev/null, so the pool's forked worker sent its results nowhere and a campaign in
    # that process waited for ever (tests/test_probe16_campaign.py hung in the suite)
    from pirate_bt.trace.sink import SinkProcess

    sink = SinkProcess(tmp_path / "run.jsonl", "JsonLinesWriter")
    old_fd = sink._fd
    sink.close()  # the run ended; the object lives on (a result, a recorder)
    r, w = os.pipe()  # the lowest free numbers: the closed pipe's among them
    if old_fd not in (r, w):
        os.dup2(w, old_fd)  # make sure one of the new pipe's ends has the old number
        os.close(w)
        w = old_fd
    pid = os.fork()
    if pid == 0:  # the child: its copy of the new pipe must still be that pipe
        try:
            os.write(w, b"through")
        finally:
            os._exit(0)
    os.close(w)
    _, status = os.waitpid(pid, 0)
    assert os.waitstatus_to_exitcode(status) == 0
    with os.fdopen(r, "rb") as reading:
        assert reading.read() == b"through"
    assert sink.path.exists()


def test_simulate_mission_never_writes_its_report_over_its_own_route(tmp_path: Path) -> None:
    # the command line refuses it since 478465f; simulate_mission(output=DIR) ran the
    # mission and wrote its report over a route kept as DIR/report.md
    repo = Path(__file__).resolve().parent.parent
    route = tmp_path / "report.md"
    route.write_text((repo / "scenarios" / "t-joint-straight.route").read_text())
    before = route.read_bytes()
    with pytest.raises(InputError) as caught:
        pirate_bt.simulate_mission(route, output=tmp_path)
    assert str(caught.value).endswith("where the mission writes its report.md; name another folder")
    assert route.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report.md"]


@pytest.mark.parametrize("extra", [["--slope", "1000deg"], ["--slope", "20deg", "--scale", "10"]])
def test_a_slope_bound_past_plumb_is_refused(
    extra: list[str], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # it was taken, every slope clamped to 90, and the file's header said "slopes ±1000 deg"
    repo = Path(__file__).resolve().parent.parent
    out = tmp_path / "v.yaml"
    argv = ["network", "perturb", str(repo / "scenarios" / "lab.yaml"), "--seed", "1"]
    assert cli.main([*argv, *extra, "-o", str(out)]) == 2
    said = capsys.readouterr().err.strip().splitlines()
    assert len(said) == 1 and "is more than 90 deg, past plumb" in said[0]
    assert not out.exists()
    from pirate_bt.errors import ConfigurationError
    from pirate_bt.pipes.asbuilt import AsBuiltBounds

    with pytest.raises(ConfigurationError, match="past plumb"):
        AsBuiltBounds(slope_rad=2.0)
