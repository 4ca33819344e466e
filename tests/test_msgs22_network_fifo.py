"""A network named by a path that is a named pipe (fifo): ``pirate-bt sim``,
``mission --sim`` said "no network 'vf.yaml'" as if nothing were there. They now say
what it is, exit 2, and never open it (a fifo's open blocks with no writer)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from pirate_bt.cli import main

pytestmark = pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no named pipes here")


@pytest.fixture
def fifo(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> str:
    os.mkfifo(tmp_path / "vf.yaml")
    monkeypatch.chdir(tmp_path)
    return "vf.yaml"


@pytest.mark.parametrize(
    "argv",
    [["sim", "{}", "--duration", "0.1"], ["mission", "lab", "--sim", "{}"]],
    ids=["sim", "mission"],
)
def test_a_named_pipe_given_as_network_is_named_so(
    fifo: str, argv: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    assert main([a.format(fifo) for a in argv]) == 2
    err = capsys.readouterr().err
    assert "'vf.yaml': it is a named pipe" in err, err
    assert err.count("\n") == 1, err
