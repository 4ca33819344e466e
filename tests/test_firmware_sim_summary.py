"""The closing summary of ``pirate-bt sim NETWORK --firmware ELF``.

The bridge firmware polls every board once per state period; the harness answers
each ``EXCHANGE`` itself and forwards to the Python boards only the frames that
differ from the last one to their board. The summary's "board exchanges" must
count what happened on the bus, not what was forwarded (it once said 101 for
~34,000 exchanges). Skipped with the reason when the AVR toolchain or
libsimavr-dev is missing.
"""

from __future__ import annotations

import re
import subprocess
import sys

import pytest
from firmware_sim_support import build, missing_toolchain

from pirate_bt.robot import load_robot


@pytest.mark.skipif(
    missing_toolchain() is not None, reason=f"firmware in simavr: {missing_toolchain()}"
)
def test_summary_counts_every_board_exchange_on_the_bus() -> None:
    elf, _ = build()
    command = [sys.executable, "-m", "pirate_bt", "sim", "straight", "--firmware", str(elf)]
    done = subprocess.run(
        [*command, "--boot-ms", "0", "--duration", "2"],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    summary = done.stderr.strip().splitlines()[-1]
    simulated = re.search(r"simulated ([\d.]+) s", summary)
    exchanges = re.search(r" (\d+) board exchanges,", summary)
    assert simulated is not None and exchanges is not None, summary
    # No host: the boot's setpoints, every frame to a board repeats the last one.
    robot = load_robot()
    polls = len(robot.board_ids()) * float(simulated.group(1)) / robot.bridge.state_period
    assert 0.8 * polls <= int(exchanges.group(1)) <= 1.2 * polls, summary
