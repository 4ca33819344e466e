"""The seventeenth probe of "a result says why" (docs/api.md, docs/missions.md,
docs/observability.md), each test written from what a planner writer or an operator saw.

- ``pirate-bt trace summary`` of a failed run said ``outcome failure`` and nowhere why:
  the end record's reason (the first cause the run printed) was not shown.
- ``pirate-bt mission --output`` onto a disk that filled up during the run said only
  *pirate-bt: No space left on device* (no file named), exit 2: the mission's own line
  with its first cause was never printed, and a 0-byte ``belief.png`` was left behind;
  ``simulate_mission(output=...)`` raised the bare ``OSError`` and the result was lost.
"""

from __future__ import annotations

import errno
from pathlib import Path
from typing import Any

import pytest

import pirate_bt
from pirate_bt.cli import main

STALL = "motor_stall:bend_1_drive@1s+20s"


def _route(tmp_path: Path) -> Path:
    route = tmp_path / "short.route"
    route.write_text("network straight\nforward 0.2 m\n", encoding="utf-8")
    return route


def _disk_full_on_pngs(monkeypatch: pytest.MonkeyPatch) -> None:
    """Every picture matplotlib writes gets a few bytes out, then finds the disk full."""
    from matplotlib.figure import Figure

    def savefig(self: Figure, fname: Any, *args: Any, **kwargs: Any) -> None:
        if isinstance(fname, str | Path):
            with open(fname, "wb") as stream:
                stream.write(b"\x89PNG")
        else:
            fname.write(b"\x89PNG")
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(Figure, "savefig", savefig)


@pytest.mark.parametrize(("faults", "code"), [(STALL, 1), (None, 0)])
def test_a_plot_on_a_full_disk_is_named_and_left_out_and_the_mission_line_stands(
    faults: str | None,
    code: int,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    _disk_full_on_pngs(monkeypatch)
    out = tmp_path / "out"
    argv = ["mission", str(_route(tmp_path)), "-q", "--output", str(out)]
    assert main([*argv, *(["--faults", faults] if faults else [])]) == code
    printed = capsys.readouterr()
    err = printed.err
    if faults:  # was: "pirate-bt: No space left on device", exit 2, the stall unsaid
        assert "pirate-bt: mission short: FAILED - stall: bend_1_drive" in err
    else:
        assert "mission short: SUCCESS" in printed.out
    assert f"pirate-bt: no belief plot: {out / 'belief.png'}: No space left on device" in err
    assert not (out / "belief.png").exists()  # nothing half-written (it was 0 bytes)
    assert not [p.name for p in out.iterdir() if p.name.endswith(".part")]
    report = (out / "report.md").read_text(encoding="utf-8")  # the report is written
    assert "belief.png" not in report


@pytest.mark.parametrize(("faults", "code"), [(STALL, 1), (None, 2)])
def test_a_report_that_cannot_be_written_keeps_the_missions_line_and_code(
    faults: str | None, code: int, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "out"
    (out / "report.html").mkdir(parents=True)  # the report's page cannot be written
    argv = ["mission", str(_route(tmp_path)), "-q", "--output", str(out)]
    assert main([*argv, *(["--faults", faults] if faults else [])]) == code
    lines = capsys.readouterr().err.splitlines()
    said = "FAILED - stall: bend_1_drive" if faults else "SUCCESS - mission completed"
    # the mission's own line, then the output's (only the output's was printed, exit 2)
    assert lines[-2].startswith(f"pirate-bt: mission short: {said}"), lines
    # the option typed (it said "output:", the API's parameter, until the 21st session)
    assert lines[-1] == f"pirate-bt: --output: cannot write {out / 'report.html'}: Is a directory"


def test_simulate_mission_whose_report_cannot_be_written_keeps_its_result(
    tmp_path: Path,
) -> None:
    out = tmp_path / "out"
    (out / "report.html").mkdir(parents=True)
    with pytest.raises(pirate_bt.InputError) as refused:  # was a bare IsADirectoryError
        pirate_bt.simulate_mission(_route(tmp_path), output=out, faults=STALL)
    message = str(refused.value)
    assert message.startswith(f"output: cannot write {out / 'report.html'}: Is a directory;")
    assert "the mission itself: mission short: FAILED - stall: bend_1_drive" in message
    assert refused.value.result.why.startswith("stall: bend_1_drive")  # type: ignore[attr-defined]


@pytest.mark.parametrize(
    ("faults", "why"),
    [
        (STALL, "why       stall: bend_1_drive draws 1.50 A"),
        ("sensor_dropout:bend_1_spring@2s", "why       stale data: bend_1_spring (0.150 s)"),
    ],
)
def test_trace_summary_says_why_the_run_ended(
    faults: str, why: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    trace = tmp_path / "run.jsonl"
    argv = ["run", "straight", "--param", "distance=1m", "-q", "--trace", str(trace)]
    assert main([*argv, "--faults", faults]) == 1
    printed = capsys.readouterr().err.strip().splitlines()[-1]
    assert main(["trace", "summary", str(trace)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[2] == "outcome   failure"
    assert lines[3].startswith(why), lines[:5]  # the same first cause as the run's line
    assert lines[3][len("why       ") :] in printed


def test_a_tree_diagram_that_cannot_be_written_is_left_out_and_the_report_written(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "out"
    (out / "tree.dot").mkdir(parents=True)  # as a full disk refuses the diagram's source
    argv = ["mission", str(_route(tmp_path)), "-q", "--output", str(out)]
    assert main([*argv, "--faults", STALL]) == 1  # was 2, the mission's line unprinted
    err = capsys.readouterr().err
    # "out:" was render_tree's parameter, an option of no command
    assert f"pirate-bt: no tree diagram: --output: cannot write '{out / 'tree.dot'}'" in err
    assert "pirate-bt: mission short: FAILED - stall: bend_1_drive" in err
    assert "stall: bend_1_drive" in (out / "report.md").read_text(encoding="utf-8")
