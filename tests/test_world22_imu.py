"""A turn the IMU never felt, which the bend PAB through it passed: a stuck IMU pitch
is the suspect, not the map (docs/missions.md)."""

from __future__ import annotations

import pirate_bt
from pirate_bt.pipes import load_network
from pirate_bt.pipes.asbuilt import remove_feature


def test_an_imu_stuck_through_a_riser_s_foot_is_suspected_not_the_map_alone() -> None:
    # was: "belief and map disagree: the map has 'foot' at 1.00-1.14 m, but no turn was
    # felt by 2.34 m (believed)", nothing more, though the bend PAB had passed 'foot'
    result = pirate_bt.simulate_mission("riser", faults="sensor_stuck:imu.pitch@3s+60s")
    assert result.exit_code == 1 and result.safe_state
    assert result.why.startswith("belief and map disagree: the map has 'foot'"), result.why
    assert result.why.endswith(
        "; yet the bend PAB through 'foot' completed before it, so the IMU, which swung"
        " 0 deg of the 90 deg turn, may be stuck"
    ), result.why
    assert [p.outcome for p in result.pabs][:3] == ["success", "success", "stopped"]
    assert result.counters.violations == 0


def test_a_turn_missing_where_the_bend_pab_found_none_blames_the_map_alone() -> None:
    truth = remove_feature(load_network("riser").spec, "foot")
    result = pirate_bt.simulate_mission("riser", truth=truth)
    assert result.exit_code == 1
    assert "no turn was felt" in result.why and "may be stuck" not in result.why
