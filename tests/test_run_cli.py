"""`pirate-bt run`: connected through the protective layer, traced, watched, honest exit codes."""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.cli import main
from pirate_bt.trace import read_trace

REPO = Path(__file__).resolve().parent.parent
STRAIGHT = str(REPO / "trees" / "straight.yaml")


def test_run_writes_a_trace_with_verdicts_and_simulator_counters(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    trace_path = tmp_path / "run.jsonl"
    code = main(
        ["run", STRAIGHT, "--param", "distance=0.3m", "--quiet", "--trace", str(trace_path)]
    )
    assert code == 0, capsys.readouterr().err
    assert "straight: SUCCESS" in capsys.readouterr().out
    trace = read_trace(trace_path)
    assert trace.outcome == "success"
    commands = [c for f in trace.frames() for c in (f.commands or ())]
    assert any("clamp(rear" in str(c) for c in commands)
    last = trace.frame_at(trace.last_tick)
    assert last.sim is not None and last.sim["violations"] == 0.0
    assert last.sim["distance_m"] >= 0.3


def test_live_view_shows_the_tree_unless_quiet(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["run", STRAIGHT, "--param", "distance=0.1m"]) == 0
    assert "drive straight" in capsys.readouterr().err
    assert main(["run", STRAIGHT, "--param", "distance=0.1m", "--quiet"]) == 0
    assert "drive straight" not in capsys.readouterr().err


def test_a_failed_run_says_why_and_leaves_the_robot_safe(
    capsys: pytest.CaptureFixture[str],
) -> None:
    code = main(
        [
            "run", STRAIGHT, "--param", "distance=1.5m", "--quiet",
            "--faults", "motor_stall:bend_3_drive@5s+20s",
        ]
    )  # fmt: skip
    assert code == 1
    err = capsys.readouterr().err
    assert "FAILURE" in err and "stall: bend_3_drive" in err


def test_connection_errors_and_misplaced_faults(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["run", STRAIGHT, "--param", "distance=1m", "--port", "/dev/no-such-port"]) == 3
    assert "cannot open /dev/no-such-port" in capsys.readouterr().err
    code = main(
        ["run", STRAIGHT, "--param", "distance=1m", "--port", "loop://", "--faults", "x:y@1s"]
    )
    assert code == 2
    assert "need the simulator" in capsys.readouterr().err


def test_pab_steps_are_the_confirmation_points(tmp_path: Path) -> None:
    """Plots shade a PAB's steps: every step sits behind a confirm node."""
    trace_path = tmp_path / "run.jsonl"
    args = ["run", STRAIGHT, "--param", "distance=0.2m", "--quiet", "--trace", str(trace_path)]
    assert main(args) == 0
    steps = [node.name for node in read_trace(trace_path).structure.steps()]
    assert steps[:2] == ["hold", "confirm drive"]


def test_faults_mean_the_same_in_run_and_mission() -> None:
    from pirate_bt.cli.run import split_faults

    assert split_faults("motor_stall:bend_1_drive@30s+5s,board_reset:22@10s") == (
        ["motor_stall:bend_1_drive@30s+5s", "board_reset:22@10s"],
        None,
    )
    assert split_faults("drop=0.05,corrupt=0.01; link_loss@12s+500ms") == (
        ["link_loss@12s+500ms"],
        "drop=0.05,corrupt=0.01",
    )
    assert split_faults(None) == ([], None)


def test_a_bundled_route_by_its_bare_name_is_the_route_not_its_network(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    # `pirate-bt mission straight` read the network scenarios/straight.yaml as a route
    # (one "unknown command" line per line of YAML); load_route("straight") did not
    monkeypatch.chdir(tmp_path)
    assert main(["mission", "straight", "--quiet"]) == 0
    out = capsys.readouterr().out
    assert "mission straight: SUCCESS" in out


def test_a_firmware_only_option_without_firmware_is_refused(
    capsys: pytest.CaptureFixture[str],
) -> None:
    # `sim --boot-ms` without --firmware was accepted and silently ignored
    assert main(["sim", "straight", "--boot-ms", "100", "--duration", "1"]) == 2
    err = capsys.readouterr().err
    assert err.strip() == (
        "pirate-bt: --boot-ms is for --firmware (the bridge's bootloader time):"
        " add --firmware ELF or drop it"
    )
