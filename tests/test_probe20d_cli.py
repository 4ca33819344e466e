"""Probe 20d, the command-line contract: an output that cannot be written is named by
the file and the option the user typed, never by a library parameter or not at all."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from pirate_bt.cli import main

needs_dev_full = pytest.mark.skipif(
    not os.path.exists("/dev/full"), reason="needs /dev/full (a device that is always full)"
)


def _full(tmp_path: Path, name: str) -> Path:
    """``name`` in ``tmp_path``: a link to /dev/full, a file whose every write fails with
    'No space left on device', as a full disk's does."""
    path = tmp_path / name
    path.symlink_to("/dev/full")
    return path


@needs_dev_full
def test_a_header_onto_a_full_disk_names_the_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = _full(tmp_path, "layout.h")
    assert main(["robot", "header", "-o", str(out)]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    # was "pirate-bt: No space left on device": which file, of which command?
    assert captured.err.splitlines() == [f"pirate-bt: {out}: No space left on device"]
