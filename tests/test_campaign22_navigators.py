"""Session 22: an installed navigator that ends or hangs the process it is made in is
refused at its run, in one line, where it ended or hung `validate` and `campaign`."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

PLUG_IN = textwrap.dedent(
    """
    import os, signal, time

    class ExitsAsMade:
        def __init__(self, **params):
            os._exit(7)
        def next_step(self, obs):
            return None

    class KilledCheckingItsMap:
        def check_map(self, network):
            os.kill(os.getpid(), signal.SIGKILL)
        def next_step(self, obs):
            return None

    class HangsAsMade:
        def __init__(self, **params):
            while True:
                time.sleep(0.2)
        def next_step(self, obs):
            return None

    class ForksAndExits:
        def __init__(self, **params):
            if os.fork() != 0:
                os._exit(0)  # the parent goes; its child carries on as if it were made
        def next_step(self, obs):
            return None
    """
)

ENTRY_POINTS = """\
[pirate_bt.navigators]
exits = rogue22:ExitsAsMade
killed = rogue22:KilledCheckingItsMap
hangs = rogue22:HangsAsMade
forks = rogue22:ForksAndExits
"""


def _install(folder: Path) -> dict[str, str]:
    """The plug-in installed where a Python given this environment finds it."""
    (folder / "rogue22.py").write_text(PLUG_IN)
    info = folder / "rogue22-0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: rogue22\nVersion: 0\n")
    (info / "entry_points.txt").write_text(ENTRY_POINTS)
    return {**os.environ, "PYTHONPATH": str(folder)}


@pytest.mark.parametrize(
    ("name", "said"),
    [
        # was exit 7 and not a word
        ("exits", "ended the process as it was made (or checked its map): exit status 7"),
        # was exit 137 (-9) and not a word
        ("killed", "ended the process as it was made (or checked its map): killed by SIGKILL"),
        # was a 'validate' that never ended
        ("hangs", "was still being made (or checking its map) after 2 s, the case timeout"),
        # was exit 0 and not a word: 'validate' ended, its forked child went on
        ("forks", "ended the process as it was made (or checked its map): exit status 0"),
    ],
    ids=["os-exit", "sigkill", "hang", "fork"],
)
def test_a_navigator_that_ends_or_hangs_its_process_is_refused_at_its_run(
    tmp_path: Path, name: str, said: str
) -> None:
    env = _install(tmp_path)
    spec = tmp_path / "n.campaign.yaml"
    spec.write_text(
        f"name: n\nruns:\n  - {{name: r, navigator: {name}, network: lab}}\ncase_timeout: 2 s\n"
    )
    out = tmp_path / "out"
    for verb in (["validate"], ["campaign", "-q", "--output", str(out)]):
        done = subprocess.run(
            [sys.executable, "-m", "pirate_bt", *verb, str(spec)],
            env=env,
            capture_output=True,
            text=True,
            timeout=120,  # killed after it (subprocess.run)
        )
        assert done.returncode == 2, (verb, done.returncode, done.stderr[-500:])
        prefix = "pirate-bt: " if verb[0] == "campaign" else ""
        assert done.stderr.splitlines() == [
            f"{prefix}{spec}:3:15: run 'r': navigator {name!r} {said}"
            + (
                "; each case would die of it"
                if "ended" in said
                else ": each case would time out making it"
            )
        ]
    assert not out.exists()


def test_the_navigators_not_rehearsed_are_the_built_in_ones() -> None:
    from pirate_bt.campaign.navchecks import BUILT_IN_NAVIGATORS
    from pirate_bt.task import navigators

    assert set(navigators._BUILT_IN) == BUILT_IN_NAVIGATORS


def _one_thread(monkeypatch: pytest.MonkeyPatch) -> None:
    """The rehearsal as the command line has it, one thread: a worker of the suite may
    hold others (a test's server), and the rehearsal is skipped there (cd8474b)."""
    from types import SimpleNamespace

    from pirate_bt.campaign import rehearsal

    monkeypatch.setattr(rehearsal, "threading", SimpleNamespace(active_count=lambda: 1))


def test_a_word_the_rehearsal_s_child_says_just_before_it_ends_is_heard(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    import select
    from types import SimpleNamespace

    from pirate_bt.campaign import rehearsal

    real_fork, real_select = os.fork, select.select
    children: list[int] = []

    def fork() -> int:
        pid = real_fork()
        if pid:
            children.append(pid)
        return pid

    waits: list[object] = []

    def late(read: list[int], write: list[int], error: list[int], timeout: float) -> object:
        waits.append(timeout)
        if len(waits) == 1:  # its word and its end both come while this wait runs out
            real_select(read, [], [], 30)
            os.waitid(os.P_PID, children[0], os.WEXITED | os.WNOWAIT)  # ended, not reaped
            return [], [], []
        return real_select(read, write, error, timeout)

    monkeypatch.setattr(os, "fork", fork)
    monkeypatch.setattr(rehearsal, "select", SimpleNamespace(select=late))
    _one_thread(monkeypatch)
    # a navigator made and checked at once: its end was seen, and its word left unread
    # ("ended the process as it was made ...: exit status 0")
    rehearsal.rehearse("fine", lambda: None, 30.0)
    assert len(waits) == 2


class SlowToMake:
    """A plug-in navigator that takes a while to be made (a model to load)."""

    def __init__(self, **params: str) -> None:
        import time

        time.sleep(1.5)

    def next_step(self, obs: object) -> None:  # pragma: no cover - never asked
        return None


def test_a_case_timeout_given_beside_the_spec_s_is_the_rehearsal_s_limit(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    from importlib.metadata import EntryPoint

    from pirate_bt.campaign import campaign_from_data, expand
    from pirate_bt.campaign.checks import check_runs
    from pirate_bt.errors import InputError
    from pirate_bt.task import navigators as registry

    plugin = EntryPoint(
        name="slow", value=f"{__name__}:SlowToMake", group=registry.ENTRY_POINT_GROUP
    )
    monkeypatch.setattr(registry, "entry_points", lambda group: [plugin])
    _one_thread(monkeypatch)
    spec = campaign_from_data(
        {"name": "s", "runs": [{"navigator": "slow", "network": "lab"}], "case_timeout": "0.5 s"},
        base=tmp_path,
    )
    cases = expand(spec, tmp_path)
    with pytest.raises(InputError, match=r"still being made .* after 0\.5 s"):
        check_runs(cases, spec, tmp_path)
    # --case-timeout 60 s (case_timeout=60): its cases have a minute each to make it, and
    # it was refused all the same after the spec's half second
    check_runs(cases, spec, tmp_path, 60.0)
