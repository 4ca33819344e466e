"""The sixteenth probe of campaigns: what a user meets with hostile outputs and specs.

1. A disk that filled while a campaign ran: ``results.jsonl`` was left cut in the
   middle of a row (8 kB of buffered rows went out in part) and the command said
   only ``pirate-bt: No space left on device``, naming no file. Now each row is one
   append, a refused one is undone to the last whole row, and the error names the
   file, the case and says to ``--resume``.
2. A report file the disk had no room for: the same bare line, and a plot's part file
   left behind. Now named, with how to write the report again.
3. ``--resume`` on a disk still full: the same, and ``results.jsonl.part`` left behind.
4. ``--output .`` in a project: its own ``report.md`` / ``results.csv`` were replaced by
   the campaign's report. Refused before any case when the folder holds no row and no
   ``campaign.json``.
5. A second Ctrl-C while a stopped campaign waited for its cases in flight: the process
   hung in ``multiprocessing``'s exit (a third: a traceback). Now it kills the workers.
6. A simulator fault due after ``max_time`` never happened: its axis point was a copy of
   the point without it. Refused at its entry (not beside a route run).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from pirate_bt.campaign import make_executor, read_rows, run_cases
from pirate_bt.campaign.sink import RowSink
from pirate_bt.errors import InputError

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="needs Linux")

HELPER = textwrap.dedent(
    """
    def behave(case, trace_dir):
        return {"id": case["id"], "index": case["index"], "run": case["run"],
                "outcome": "success", "reason": "fine " + "x" * 200, "seed": case["seed"]}
    """
)


def _cases(n: int) -> list[dict[str, object]]:
    return [
        {"id": f"{i:06d}-p16", "index": i, "run": "r", "seed": i, "timeout_s": 60.0}
        for i in range(n)
    ]


@pytest.fixture
def helper(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    (tmp_path / "probe16_helper.py").write_text(HELPER, encoding="utf-8")
    monkeypatch.setenv("PYTHONPATH", f"{tmp_path}{os.pathsep}{os.environ.get('PYTHONPATH', '')}")
    return tmp_path


# no bytecode written under a file size limit: a cut .pyc of a module changed since its
# last import would break every later import of it in the shared tree
def _no_bytecode() -> dict[str, str]:
    return {**os.environ, "PYTHONDONTWRITEBYTECODE": "1"}  # at the call: the helper's path


# The campaign in a Python of its own whose files may not grow past LIMIT bytes
# (RLIMIT_FSIZE: a write past it fails with EFBIG, as one fails on a full disk).
FULL = textwrap.dedent(
    """
    import resource, sys
    from pathlib import Path
    from pirate_bt.campaign import make_executor, run_cases
    from pirate_bt.errors import InputError
    sys.path.insert(0, sys.argv[1])
    from test_probe16_campaign import _cases
    limit = int(sys.argv[3])
    with make_executor(workers=1) as (executor, _):
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
        try:
            run_cases(_cases(6), Path(sys.argv[2]), executor, target="probe16_helper:behave")
        except InputError as exc:
            print(exc, file=sys.stderr)
            sys.exit(2)
    """
)


def test_a_disk_that_fills_leaves_whole_rows_and_names_the_results_file(helper: Path) -> None:
    out = helper / "out"
    # the size of two rows and a half
    row = len(json.dumps({"id": "000000-p16", "index": 0, "run": "r"})) + 240
    done = subprocess.run(
        [sys.executable, "-c", FULL, str(Path(__file__).parent), str(out), str(row * 5 // 2)],
        env=_no_bytecode(),
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert done.returncode == 2, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1, done.stderr
    results = out / "results.jsonl"
    assert lines[0].startswith(f"{results}: cannot write case 0000"), lines[0]
    assert "resume=True" in lines[0]  # run_cases: the API's words
    text = results.read_text(encoding="utf-8")
    assert text.endswith("\n")  # no cut row
    kept = [json.loads(line) for line in text.splitlines()]
    assert 1 <= len(kept) < 6
    # and --resume, with room again, runs exactly the missing cases
    with make_executor(workers=1) as (executor, _):
        rows = run_cases(_cases(6), out, executor, resume=True, target="probe16_helper:behave")
    assert [r["index"] for r in rows] == list(range(6))
    assert [r["index"] for r in read_rows(results)] == [r["index"] for r in kept] + [
        i for i in range(6) if i not in {r["index"] for r in kept}
    ]


def test_a_row_the_file_system_refuses_names_the_file() -> None:
    with RowSink(Path("/dev/full")) as sink, pytest.raises(InputError) as caught:
        sink.write({"id": "000003-ab", "index": 3})
    assert str(caught.value).startswith("/dev/full: cannot write case 000003-ab's row: No space")


# 2. A report the disk had no room for: "pirate-bt: No space left on device", naming no
#    file, and a plot's ".success_vs_drop.part.png" left in the folder. Now one line
#    naming the file and how to write the report again; no part file.


def _rows() -> list[dict[str, object]]:
    return [
        {"id": f"{i:06d}-p16", "index": i, "run": "r", "seed": 0, "drop": drop}
        | {"outcome": "success", "reason": "fine", "sim_time_s": 1.0}
        for i, drop in enumerate([0.0, 0.1])
    ]


def test_a_report_file_the_disk_refuses_is_named(tmp_path: Path) -> None:
    from pirate_bt.campaign.report import write_report

    (tmp_path / "results.csv").symlink_to("/dev/full")  # a write there: ENOSPC
    with pytest.raises(InputError) as caught:
        write_report(_rows(), tmp_path, title="t")
    results = tmp_path / "results.jsonl"
    assert str(caught.value) == (
        f"{tmp_path / 'results.csv'}: cannot write the report: No space left on device;"
        f" the rows stay in {results}: make room, then `pirate-bt campaign report {results}`"
    )


PLOT = textwrap.dedent(
    """
    import resource, sys
    from pathlib import Path
    from pirate_bt.campaign.report import write_report
    from pirate_bt.errors import InputError
    sys.path.insert(0, sys.argv[1])
    from test_probe16_campaign import _rows
    import matplotlib.pyplot
    resource.setrlimit(resource.RLIMIT_FSIZE, (4000, 4000))  # the csv fits, no plot does
    try:
        write_report(_rows(), Path(sys.argv[2]), title="t")
    except InputError as exc:
        print(exc, file=sys.stderr)
        sys.exit(2)
    """
)


def test_a_plot_the_disk_refuses_is_named_and_leaves_no_part_file(tmp_path: Path) -> None:
    done = subprocess.run(
        [sys.executable, "-c", PLOT, str(Path(__file__).parent), str(tmp_path)],
        env=_no_bytecode(),
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert done.returncode == 2, done.stderr
    assert done.stderr.startswith(f"{tmp_path / 'success_vs_drop.png'}: cannot write the report")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["results.csv"]


# 3. --resume on a disk still full: the results file is rewritten first (without a cut
#    last line); that failed with "No space left on device" and left results.jsonl.part.


RESUME = textwrap.dedent(
    """
    import resource, sys
    from pathlib import Path
    from pirate_bt.campaign import make_executor, run_cases
    from pirate_bt.errors import InputError
    sys.path.insert(0, sys.argv[1])
    from test_probe16_campaign import _cases
    with make_executor(workers=1) as (executor, _):
        resource.setrlimit(resource.RLIMIT_FSIZE, (100, 100))  # less than the results
        try:
            run_cases(_cases(3), Path(sys.argv[2]), executor, resume=True,
                      target="probe16_helper:behave")
        except InputError as exc:
            print(exc, file=sys.stderr)
            sys.exit(2)
    """
)


def test_a_resume_the_disk_has_no_room_for_names_the_results_and_keeps_them(
    helper: Path,
) -> None:
    out = helper / "out"
    out.mkdir()
    results = out / "results.jsonl"
    row = {"id": "000000-p16", "index": 0, "run": "r", "seed": 0, "outcome": "success"}
    before = json.dumps(row | {"reason": "fine " + "x" * 200}) + "\n" + '{"id": "0000'
    results.write_text(before, encoding="utf-8")  # a cut last line: rewritten to resume
    done = subprocess.run(
        [sys.executable, "-c", RESUME, str(Path(__file__).parent), str(out)],
        env=_no_bytecode(),
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert done.returncode == 2, done.stderr
    assert done.stderr.splitlines()[-1] == (
        f"{results}: cannot rewrite it to resume: File too large; it is as it was:"
        " make room, then run again with resume=True"
    )
    assert results.read_text(encoding="utf-8") == before
    assert sorted(p.name for p in out.iterdir()) == ["results.jsonl"]


# 4. `--output .` in a folder of one's own: its report.md, report.html, results.csv
#    were replaced by the campaign's report without a word when the campaign ended.
#    A folder without a row that holds one is refused before any case runs.


SPEC = {
    "name": "p16",
    "runs": [{"tree": "straight", "network": "straight", "params": {"distance": "0.2 m"}}],
    "max_time": "60 s",
}


@pytest.mark.parametrize("name", ["report.md", "results.csv", "success_vs_drop.png"])
@pytest.mark.parametrize("resume", [False, True])
def test_a_report_file_of_someone_elses_is_not_replaced(
    tmp_path: Path, name: str, resume: bool
) -> None:
    from pirate_bt.campaign import run_campaign

    out = tmp_path / "mine"
    out.mkdir()
    (out / name).write_text("my own notes\n", encoding="utf-8")
    if resume:
        (out / "results.jsonl").write_text("", encoding="utf-8")
    seen: list[object] = []
    with pytest.raises(InputError) as caught:
        run_campaign(SPEC, output=out, resume=resume, workers=1, on_record=seen.append)
    assert str(caught.value) == (
        f"{out / name}: the campaign's report would replace it, and it is no campaign's"
        f" ({out} holds no row, nor campaign.json); move it, or give another output="
    )
    assert seen == []
    assert (out / name).read_text(encoding="utf-8") == "my own notes\n"


def test_the_command_refuses_an_output_holding_a_report_of_its_own(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from pirate_bt.cli import main

    spec = tmp_path / "p.campaign.yaml"
    spec.write_text(json.dumps(SPEC), encoding="utf-8")
    (tmp_path / "report.md").write_text("# my project\n", encoding="utf-8")
    code = main(["campaign", str(spec), "--output", str(tmp_path), "--quiet", "--workers", "1"])
    assert code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"pirate-bt: {tmp_path / 'report.md'}: the")
    assert (tmp_path / "report.md").read_text(encoding="utf-8") == "# my project\n"
    assert not (tmp_path / "results.jsonl").exists()


# 5. Ctrl-C again while a stopped campaign waits for its cases in flight: it raised out
#    of the pool's shutdown with the workers still running, and the process then sat
#    in multiprocessing's exit joining them (a third Ctrl-C: a traceback from there).
#    Now a second interrupt kills the workers, their servers and cases, and it ends.

SLEEPER = textwrap.dedent(
    """
    import os, time
    from pathlib import Path

    def sleep(case, trace_dir):
        Path(os.environ["P16_STARTED"], str(os.getpid())).write_text("")
        time.sleep(600)
    """
)

STOPPED = textwrap.dedent(
    """
    import signal, sys
    from pathlib import Path
    from pirate_bt.campaign import make_executor, run_cases
    sys.path.insert(0, sys.argv[1])
    from test_probe16_campaign import _cases
    try:
        with make_executor(workers=2) as (executor, _):
            run_cases(_cases(2), Path(sys.argv[2]), executor, target="probe16_sleeper:sleep")
    except KeyboardInterrupt:
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        print("interrupted", file=sys.stderr)
        sys.exit(130)
    """
)


def _gone(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat", encoding="utf-8") as f:
            return f.read().rsplit(")", 1)[1].split()[0] == "Z"
    except OSError:
        return True


def test_a_second_ctrl_c_stops_a_campaign_waiting_for_its_cases(helper: Path) -> None:
    import signal
    import time

    (helper / "probe16_sleeper.py").write_text(SLEEPER, encoding="utf-8")
    started = helper / "started"
    started.mkdir()
    env = {**os.environ, "P16_STARTED": str(started)}
    command = [sys.executable, "-c", STOPPED, str(Path(__file__).parent), str(helper / "out")]
    proc = subprocess.Popen(command, env=env, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 120
        while len(list(started.iterdir())) < 2 and time.monotonic() < deadline:
            time.sleep(0.05)
        cases = [int(p.name) for p in started.iterdir()]
        assert len(cases) == 2
        # to the campaign's process alone: its cases do not see it and sleep on
        for _ in range(40):
            proc.send_signal(signal.SIGINT)
            try:
                proc.wait(timeout=0.5)
                break
            except subprocess.TimeoutExpired:
                continue
        _, err = proc.communicate(timeout=120)
    finally:
        proc.kill()
        proc.wait()
    assert proc.returncode == 130, err
    assert err.strip().splitlines() == ["interrupted"]
    deadline = time.monotonic() + 60
    while not all(map(_gone, cases)) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert all(map(_gone, cases))


# 6. A simulator fault due after max_time (`@200s` for `@20s`, max_time 60 s) never
#    happened: its point of the axis ran the runs of the point without it and the
#    report showed it as a group of its own, all success. Now refused at its entry.


def test_a_fault_due_after_max_time_is_refused_at_its_entry(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from pirate_bt.campaign import run_campaign
    from pirate_bt.cli import main

    spec = tmp_path / "late.campaign.yaml"
    spec.write_text(
        "name: late\n"
        "runs: [{tree: straight, network: straight, params: {distance: 0.2 m}}]\n"
        'sim_faults: [[], ["motor_stall:bend_1_drive@200s+2s"]]\n'
        "max_time: 60 s\n",
        encoding="utf-8",
    )
    assert main(["validate", str(spec)]) == 2
    assert capsys.readouterr().err.strip() == (
        f"{spec}:3:19: 'motor_stall:bend_1_drive@200s+2s' starts at 200 s, not before"
        " max_time (60 s): it would never happen, and its runs be those without it"
    )
    data = {**SPEC, "sim_faults": [["motor_stall:bend_1_drive@1 min"]]}
    with pytest.raises(InputError, match=r"^campaign spec: sim_faults\[0\]\[0\]: .* 60 s, not"):
        run_campaign(data, output=tmp_path / "out", workers=1)
    assert not (tmp_path / "out").exists()
    # one due before the limit still runs
    data["sim_faults"] = [["motor_stall:bend_1_drive@1s+1s"]]
    assert run_campaign(data, workers=1).cases == 1


def test_a_late_fault_beside_a_route_run_is_refused_too() -> None:
    """A mission re-planned after a stop runs its rest in the time it has left (it had a
    time limit of its own until the world probe's fix to task/replan.py)."""
    from pirate_bt.campaign.faulttimes import check_fault_times
    from pirate_bt.campaign.spec import campaign_from_data

    late = [["motor_stall:bend_1_drive@700s+2s"]]
    with pytest.raises(InputError, match="never happen"):
        check_fault_times(
            campaign_from_data({**SPEC, "runs": [{"route": "straight"}], "sim_faults": late})
        )
    with pytest.raises(InputError, match="never happen"):
        check_fault_times(campaign_from_data({**SPEC, "sim_faults": late}))


def test_an_output_folder_nobody_may_write_in_is_named_with_what_to_do(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # '--output /sys/kernel' (as root) said 'pirate-bt: /sys/kernel/.campaign.lock:
    # Permission denied': a file the user never named, and nothing of what to do
    import errno

    from pirate_bt.campaign import paths

    real_open = os.open

    def refusing_open(path: object, *args: object, **kwargs: object) -> int:
        if str(path).endswith(paths.LOCK_NAME):
            raise PermissionError(errno.EACCES, os.strerror(errno.EACCES), str(path))
        return real_open(path, *args, **kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(os, "open", refusing_open)
    with pytest.raises(InputError) as caught, paths.campaign_lock(tmp_path):
        pass
    assert str(caught.value) == (
        f"{tmp_path}: cannot write a campaign there (Permission denied); give another output="
    )
