"""A process forked while a live view's process runs (multiprocessing's ``fork``, a
campaign pool's worker, a planner's ``os.fork``) does not keep that process: closing the
Foxglove server or the ROS 2 node ends it, whatever the child does."""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent

# OPEN makes the live view as `view` and its process as `proc`; a child is forked and
# lives on; the view is closed: its process's exit code is printed.
_FORKS = """
import os, sys, time
{open}
child = os.fork()
if child == 0:
    os.dup2(os.open(os.devnull, os.O_WRONLY), 1)  # the test reads this process's lines
    time.sleep(600)  # a pool's worker, living on
    os._exit(0)
view.close()
print(proc.returncode, flush=True)
os.kill(child, 9)
os.waitpid(child, 0)
"""

_FOXGLOVE = """
from pirate_bt.interop.foxglove_live import FoxgloveServer
view = FoxgloveServer(port=0)
proc = view._proc
"""

_ROS2 = """
import json, socket, zenoh
from pirate_bt.interop.ros2_live import Ros2Node
probe = socket.socket()
probe.bind(("127.0.0.1", 0))
port = probe.getsockname()[1]
probe.close()
config = zenoh.Config()
for key, value in (
    ("mode", "router"),
    ("listen/endpoints", [f"tcp/127.0.0.1:{port}"]),
    ("scouting/multicast/enabled", False),
):
    config.insert_json5(key, json.dumps(value))
router = zenoh.open(config)
view = Ros2Node(f"tcp/127.0.0.1:{port}")
assert view.wait_ready()
proc = view._proc
"""


@pytest.mark.parametrize("view", ["foxglove", "ros2"])
def test_a_forked_child_does_not_keep_a_live_view_s_process(view: str) -> None:
    pytest.importorskip("foxglove" if view == "foxglove" else "zenoh")
    script = _FORKS.format(open=textwrap.dedent(_FOXGLOVE if view == "foxglove" else _ROS2))
    # before: -9: the child's copy of the process's pipe kept it running after close,
    # which waited 11 s for it, then killed it ("its process did not finish")
    done = subprocess.run(
        [sys.executable, "-c", script],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=120,
        check=False,
    )
    assert (done.returncode, done.stdout.strip()) == (0, "0"), done.stderr[-2000:]
    assert "did not finish" not in done.stderr
