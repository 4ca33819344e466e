"""Ctrl-C while a navigator decides its step ends the navigation as a failure that
leaves the robot safe and says why, as Ctrl-C during a step does.

It went straight out of the navigation: ``navigate()`` raised, the robot was not put
in its safe state by the navigation, and ``navigation.jsonl`` ended with
``"why": ""``.
"""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap
from pathlib import Path

SCRIPT = textwrap.dedent(
    """
    import json, os, signal, sys, time
    import pirate_bt

    class Slow:
        def next_step(self, obs):
            if obs.step == 1:
                os.kill(os.getpid(), signal.SIGINT)  # the operator's Ctrl-C, mid-decision
                time.sleep(2.0)
            return pirate_bt.Step("straight", distance="0.1 m") if obs.step < 3 else None

    result = pirate_bt.navigate(Slow(), sim="straight", trace=sys.argv[1])
    print(json.dumps({"status": result.status, "why": result.why, "steps": result.steps,
                      "safe": result.safe_state, "code": result.exit_code}))
    """
)


def test_ctrl_c_while_the_navigator_decides_is_a_safe_failure_that_says_so(
    tmp_path: Path,
) -> None:
    out = tmp_path / "nav"
    done = subprocess.run(
        [sys.executable, "-c", SCRIPT, str(out)],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    said = json.loads(done.stdout.strip().splitlines()[-1])
    assert said["status"] == "failure" and said["code"] == 1, said
    assert said["why"] == "interrupted (Ctrl-C) while navigator 'Slow' decided step 2", said
    assert said["steps"] == 1 and said["safe"] is True
    end = json.loads((out / "navigation.jsonl").read_text().splitlines()[-1])
    assert end["type"] == "end" and end["why"] == said["why"]
