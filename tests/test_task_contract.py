"""The PAB contract holds: the planner's constants match the PAB trees on the simulator.

``PabContract`` keeps, as constants, where each PAB leaves the robot; the planner
places every PAB open-loop with them. A change to a PAB tree that moves where it
ends must fail here (with the constant to change and its new value), not in the
demo, where the robot would drive into the next feature.
"""

from __future__ import annotations

import math
from dataclasses import replace

import pytest

from pirate_bt.task.calibrate import (
    DEFAULT_TOLERANCE_M,
    Calibration,
    calibrate,
    check_contract,
)
from pirate_bt.task.planner import PabContract


@pytest.fixture(scope="module")
def calibration() -> Calibration:
    return calibrate()


def test_every_pab_passes_its_scenario_cleanly(calibration: Calibration) -> None:
    cases = {m.case for m in calibration.measurements}
    assert cases == {
        "straight",
        "bend-up",
        "bend-down",
        "bend-left",
        "bend-right",
        "tee-straight",
        "tee-left",
    }
    for m in calibration.measurements:
        assert m.succeeded and m.violations == 0, f"{m.case}: {m.message}"


def test_contract_constants_match_the_pab_trees(calibration: Calibration) -> None:
    problems = check_contract(calibration, PabContract())
    assert not problems, "\n".join(problems)


def test_every_bend_module_ends_past_the_feature(calibration: Calibration) -> None:
    # The next PAB clamps at once: no bend module may be left on a turn or over an opening.
    for m in calibration.measurements:
        if not math.isnan(m.rear_clear_m):
            assert m.rear_clear_m > 0.0, m


def test_bend_orientations_agree(calibration: Calibration) -> None:
    turns = [m.value_m for m in calibration.measurements if m.case.startswith("bend")]
    assert max(turns) - min(turns) <= DEFAULT_TOLERANCE_M


def test_drift_is_reported_with_the_constant_and_its_measurement(
    calibration: Calibration,
) -> None:
    drifted = replace(PabContract(), tee_exit_m=calibration.tee_exit_m - 0.35)
    problems = check_contract(calibration, drifted)
    assert len(problems) == 1
    assert problems[0].startswith("PabContract.tee_exit_m = ")
    assert f"set tee_exit_m = {calibration.tee_exit_m:.3f}" in problems[0]


def test_contract_margin_absorbs_more_than_the_tolerance() -> None:
    # A constant may be off by up to the tolerance without the test failing; the
    # margin every leg leaves before a feature must absorb that and more.
    contract = PabContract()
    assert contract.min_margin_m >= 5 * DEFAULT_TOLERANCE_M
    assert contract.approach_m >= contract.min_margin_m
