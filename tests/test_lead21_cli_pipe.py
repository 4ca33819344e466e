"""A broken pipe is exit 0 only when it is standard output's reader that went away."""

from __future__ import annotations

import errno
import subprocess
import sys
from pathlib import Path

import pytest

from pirate_bt.cli import main

ROOT = Path(__file__).resolve().parents[1]


def test_a_broken_pipe_not_of_standard_output_is_an_error_said_in_one_line(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    # a helper process or a socket the command wrote to went away: before, every
    # BrokenPipeError was taken for `| head -1` and the command exited 0, saying nothing
    import pirate_bt.filekinds

    def broken(*args: object, **kwargs: object) -> object:
        raise BrokenPipeError(errno.EPIPE, "Broken pipe")

    monkeypatch.setattr(pirate_bt.filekinds, "validate_file", broken)
    monkeypatch.setattr("pirate_bt.cli.validate.validate_file", broken, raising=False)
    code = main(["validate", str(ROOT / "hardware" / "pirate.yaml")])
    err = capsys.readouterr().err
    assert code != 0
    assert err.count("\n") == 1 and "Broken pipe" in err, err


def test_standard_output_whose_reader_went_away_is_still_exit_0() -> None:
    # `pirate-bt schema tree | head -c 1`: the reader goes at once
    command = [sys.executable, "-m", "pirate_bt", "schema", "tree"]
    proc = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, cwd=ROOT)
    try:
        assert proc.stdout is not None and proc.stderr is not None
        proc.stdout.read(1)
        proc.stdout.close()
        err = proc.stderr.read()
        assert proc.wait(timeout=120) == 0, err
        assert b"Traceback" not in err and b"Broken pipe" not in err, err
    finally:
        proc.kill()
        proc.wait(timeout=60)
