"""Six small link-layer defects a probe found, each pinned by a test.

1. a fault kind that takes no target (``link_loss``) refuses one;
2. (see the report: not here yet);
3. ``PROTOCOL_MINOR``'s docstring says what the host asks for;
4. the hello messages name what differs;
5. the e-stop of a link's close is retried when its frame is lost;
6. a run of STATEs of another layout is a protocol mismatch, not stale data.
"""

from __future__ import annotations

import pytest

from pirate_bt.cli import main
from pirate_bt.errors import InputError
from pirate_bt.pipes import FaultSpec
from pirate_bt.robot import load_robot
from pirate_bt.sim.faults import FaultTargetError, check_fault_target, parse_fault

ROBOT = load_robot()

# -- 1. a fault kind that takes no target refuses one -----------------------------------------


@pytest.mark.parametrize("text", ["link_loss:22@1s", "link_loss:x@1s+2s"])
def test_link_loss_refuses_a_target(text: str) -> None:
    with pytest.raises(InputError, match=r"^faults: fault link_loss takes no target") as caught:
        parse_fault(text)
    assert repr(text) in str(caught.value) and "\n" not in str(caught.value)


def test_a_network_files_link_loss_with_a_target_is_refused_too() -> None:
    with pytest.raises(FaultTargetError, match=r"^fault link_loss takes no target \('22'\)"):
        check_fault_target(FaultSpec(kind="link_loss", at=1.0, target="22"), ROBOT)
    check_fault_target(FaultSpec(kind="link_loss", at=1.0), ROBOT)  # none: fine


def test_the_command_line_exits_2_naming_the_spec(capsys: pytest.CaptureFixture[str]) -> None:
    argv = ["run", "trees/straight.yaml", "--sim", "straight", "--param", "distance=0.1m"]
    assert main([*argv, "--faults", "link_loss:22@1s"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "'link_loss:22@1s'" in err and "takes no target" in err
