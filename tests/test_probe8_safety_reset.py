"""Probe 8 of the protective layer: an e-stop reset the bridge refuses ends no run.

The bridge refuses to release its e-stop (``NACK NOT_READY``) while a board is in fault,
as the firmware bridge does. The supervisor let the link's error up through its tick:
an operator's reset at the wrong moment ended the run (and the operator console) on a
link error, exit 3. The e-stop stays latched now, the refusal is logged, and a reset
once the board has recovered releases it.
"""

from __future__ import annotations

import pytest

import pirate_bt
from pirate_bt.safety import EStop, Mode, ResetEStop, ScriptedOperator, SetMode


def test_a_refused_reset_leaves_the_estop_latched_and_the_run_going(
    caplog: pytest.LogCaptureFixture,
) -> None:
    with pirate_bt.connect("straight", faults="board_fault:26@1s+2s") as robot:
        sup = robot.supervisor
        operator = ScriptedOperator(
            at_time=[
                (0.5, EStop("operator")),
                (1.5, ResetEStop()),  # board 26 in fault: NOT_READY
                (3.5, ResetEStop()),  # recovered: released, mode manual
                (3.6, SetMode(Mode.AUTONOMOUS)),  # handed back: the safe state is left
            ]
        )
        sup.add_input(operator)
        result = robot.run("straight", params={"distance": "0.2 m"}, max_time="20 s")
        # was: failure, exit 3, "LinkError: e-stop reset nacked NOT_READY"
        assert "e-stop reset refused: e-stop reset nacked NOT_READY" in caplog.text
        assert result.succeeded, result.why
        assert result.error is None and sup.mode is Mode.AUTONOMOUS
    with pirate_bt.connect("straight") as robot:
        robot.supervisor.estop("test")
        assert robot.supervisor.reset_estop() and robot.supervisor.mode is Mode.MANUAL
