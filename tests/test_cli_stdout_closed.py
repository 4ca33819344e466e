"""``-o -`` with standard output closed (``>&-``) is refused in one line, exit 2: the
text went to the null device that stands in for the closed stream, and the command
exited 0 having written nothing anywhere."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest


def _closed_stdout() -> None:
    os.close(1)


@pytest.mark.parametrize(
    ("argv", "what"),
    [
        (["export", "btcpp", "straight", "-o", "-"], "straight.xml"),
        (["import", "btcpp", "{xml}", "-o", "-"], "straight.yaml"),
        (["robot", "header"], "the header"),
        (["network", "perturb", "lab", "--seed", "3"], "the network file"),
    ],
)
def test_text_for_a_closed_standard_output_is_refused(
    argv: list[str], what: str, tmp_path: Path
) -> None:
    xml = tmp_path / "straight.xml"
    if "{xml}" in argv:
        from pirate_bt.cli import main

        assert main(["export", "btcpp", "straight", "-o", str(xml)]) == 0
    done = subprocess.run(
        [sys.executable, "-m", "pirate_bt", *(a.replace("{xml}", str(xml)) for a in argv)],
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=_closed_stdout,
        timeout=120,
        check=False,
    )
    assert done.returncode == 2, done.stderr
    assert done.stderr.strip().splitlines() == [
        f"pirate-bt: standard output is closed; {what} not written"
    ]


def test_minus_o_minus_with_stdout_open_writes_the_text() -> None:
    done = subprocess.run(
        [sys.executable, "-m", "pirate_bt", "export", "btcpp", "straight", "-o", "-"],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert done.returncode == 0 and done.stdout.startswith("<?xml"), done.stderr
