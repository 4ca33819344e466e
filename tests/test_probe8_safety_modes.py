"""Probe 8 of the protective layer: operator actions planner code or an input builds.

``SetMode("estop")`` set the supervisor's mode to the text ``"estop"``. The checks
compare modes by identity, so they saw neither an e-stop nor the operator in control:
the tree's commands passed, and the hand-back branch had even left the safe state. An
action that is no operator action (``"estop"``) was dropped without a word.
"""

from __future__ import annotations

from typing import Any

import pytest
from safety_rig import rig

from pirate_bt.errors import InputError
from pirate_bt.robot import Half
from pirate_bt.safety import (
    Clamp,
    EStop,
    Mode,
    Reason,
    ScriptedOperator,
    SetMode,
)


def test_a_mode_given_as_text_is_that_mode() -> None:
    sup, port, _ = rig()
    sup.safe_state("test")
    sup.apply(SetMode("estop"))  # type: ignore[arg-type]
    # was: mode 'estop' (text), not e-stopped, the safe state left, the clamp passed
    assert sup.mode is Mode.ESTOP and sup.estopped and port.estopped
    verdict = sup.command(Clamp(Half.FRONT, 0.7))
    assert verdict.refused and verdict.reason is Reason.ESTOP_LATCHED
    sup, _, _ = rig()
    sup.apply(SetMode("manual"))  # type: ignore[arg-type]
    assert sup.mode is Mode.MANUAL
    assert sup.command(Clamp(Half.FRONT, 0.7)).reason is Reason.TREE_PAUSED
    sup, _, _ = rig(mode="supervised")
    assert sup.mode is Mode.SUPERVISED
    assert sup.command(Clamp(Half.FRONT, 0.7)).reason is Reason.NOT_CONFIRMED


@pytest.mark.parametrize("action", [SetMode(None), SetMode("halt"), "estop", EStop])  # type: ignore[arg-type]
def test_what_is_no_action_is_refused_and_changes_nothing(action: Any) -> None:
    sup, _, _ = rig()
    sup.safe_state("test")
    with pytest.raises(InputError, match=r"not an operator action|not a mode"):
        sup.apply(action)
    assert sup.mode is Mode.AUTONOMOUS and sup.safe_state_reason == "test"


def test_an_input_s_bad_action_is_logged_and_the_rest_applied(
    caplog: pytest.LogCaptureFixture,
) -> None:
    operator = ScriptedOperator(at_tick=[(1, SetMode("nope")), (1, EStop("button"))])  # type: ignore[arg-type]
    sup, _, _ = rig(inputs=[operator])
    sup.tick()
    assert sup.estopped and sup.estop_reason == "button"
    assert "not a mode: 'nope'" in caplog.text
