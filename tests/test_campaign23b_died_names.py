"""Session 23: a case process that dies names what it ran in its row.

A plug-in navigator that closes the case process's file descriptors (``os.closerange``
in its ``next_step``) left the row *case process died (exit status 1): OSError: [Errno
9] Bad file descriptor*, naming neither the navigator nor the run. The row now reads
*case process died (exit status 1) in navigator 'closesfds' (run 'r', seed 0): OSError:
...*; a tree's or route's case names its file, and the report counts seeds alike.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

PLUG_IN = textwrap.dedent(
    """
    import os

    class ClosesFds:
        def __init__(self, **params):
            pass
        def next_step(self, obs):
            os.closerange(3, 65536)
            return None
    """
)


def _install(folder: Path) -> dict[str, str]:
    """The plug-in installed where a Python given this environment finds it."""
    (folder / "fdnav23b.py").write_text(PLUG_IN)
    info = folder / "fdnav23b-0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: fdnav23b\nVersion: 0\n")
    (info / "entry_points.txt").write_text(
        "[pirate_bt.navigators]\nclosesfds = fdnav23b:ClosesFds\n"
    )
    return {**os.environ, "PYTHONPATH": str(folder)}


def test_a_navigator_that_closes_the_case_s_files_is_named_in_its_row(tmp_path: Path) -> None:
    env = _install(tmp_path)
    spec = tmp_path / "n.campaign.yaml"
    spec.write_text("name: n\nruns:\n  - {name: r, navigator: closesfds, network: lab}\n")
    out = tmp_path / "out"
    done = subprocess.run(
        [sys.executable, "-m", "pirate_bt", "campaign", "-q", "--output", str(out), str(spec)],
        env=env,
        capture_output=True,
        text=True,
        timeout=180,  # killed after it (subprocess.run)
    )
    assert done.returncode == 0, done.stderr[-500:]
    (row,) = [json.loads(line) for line in (out / "results.jsonl").read_text().splitlines()]
    assert row["outcome"] == "error"
    assert row["reason"].startswith(
        "case process died (exit status 1) in navigator 'closesfds' (run 'r', seed 0): "
    ), row["reason"]
    assert "Bad file descriptor" in row["reason"]


def test_a_tree_or_route_case_is_named_by_its_file() -> None:
    from pirate_bt.campaign.workers import _what_ran

    tree = {"run": "t", "seed": 4, "tree": "/x/trees/straight.yaml", "route": None}
    assert _what_ran(tree) == "tree 'straight.yaml' (run 't', seed 4)"
    route = {"run": "m", "seed": 0, "tree": None, "route": "/x/lab.route"}
    assert _what_ran(route) == "route 'lab.route' (run 'm', seed 0)"
    assert _what_ran({"run": "own", "seed": 1}) == "run 'own', seed 1"
