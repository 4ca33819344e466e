"""Session 23: an as-built variant keeps the robot put in on straight pipe.

A variant at a wide scale could shorten the straight before the first bend below the
robot's length (at ``scale: 10``, about one riser variant in four): the robot was put
in across the bend, and the simulator now refuses such a truth (every such case an
error row, ``network perturb`` a file no mission could run in). With
``AsBuiltBounds(put_in_m=...)``, the robot's length, as a campaign's ``as_built`` and
``pirate-bt network perturb`` give it, the straight just before the first bend or
T-joint is lengthened in a variant that needs it; the others are as they were.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.cli import main
from pirate_bt.pipes import Network, load_network
from pirate_bt.pipes.asbuilt import AsBuiltBounds, perturb_network
from pirate_bt.robot import load_robot
from pirate_bt.sim.simulator import put_in_problem

ROBOT = load_robot()
LENGTH_M = sum(module.length for module in ROBOT.modules)
SEEDS = range(40)


def test_wide_variants_put_the_robot_in_on_straight_pipe() -> None:
    riser = load_network("riser").spec
    wide = AsBuiltBounds().scaled(10)
    kept = AsBuiltBounds(put_in_m=LENGTH_M).scaled(10)
    across = [s for s in SEEDS if put_in_problem(Network(perturb_network(riser, s, wide)), ROBOT)]
    assert across  # without the bound, some are (the case this guards)
    for seed in SEEDS:
        variant = perturb_network(riser, seed, kept)
        assert put_in_problem(Network(variant), ROBOT) is None, seed
        if seed not in across:  # a variant that did not need it is the one it was
            assert variant.segments == perturb_network(riser, seed, wide).segments


def test_network_perturb_writes_a_variant_the_simulator_takes(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    riser = load_network("riser").spec
    seed = next(
        s
        for s in SEEDS
        if put_in_problem(Network(perturb_network(riser, s, AsBuiltBounds().scaled(10))), ROBOT)
    )
    out = tmp_path / "v.yaml"
    argv = ["network", "perturb", "riser", "--seed", str(seed), "--scale", "10", "-o", str(out)]
    assert main(argv) == 0
    capsys.readouterr()
    assert put_in_problem(load_network(out), ROBOT) is None
    assert "the first bend or T-joint at least 0.515 m in" in out.read_text(encoding="utf-8")


def test_a_campaign_case_s_variant_puts_its_robot_in_on_straight_pipe() -> None:
    from pirate_bt.campaign.case import _as_built

    for seed in SEEDS:
        case = {"as_built": seed, "as_built_scale": 10.0, "robot": None}
        assert put_in_problem(_as_built(case, "riser"), ROBOT) is None, seed
