"""The faults option's items: a number and its time unit written apart stay one item."""

from __future__ import annotations

from pathlib import Path

import pytest

import pirate_bt
from pirate_bt.api.fault_text import fault_items, split_faults
from pirate_bt.cli import main


@pytest.mark.parametrize(
    ("text", "items"),
    [
        ("motor_stall:bend_1_drive@2 s", ["motor_stall:bend_1_drive@2 s"]),
        ("motor_stall:rotate@1 s+0.5 s; drop=0.1", ["motor_stall:rotate@1 s+0.5 s", "drop=0.1"]),
        ("delay=20 ms, dup=0.1", ["delay=20 ms", "dup=0.1"]),
        ("drop=0.05 corrupt=0.01", ["drop=0.05", "corrupt=0.01"]),  # still two
        ("a@1s  b@2s", ["a@1s", "b@2s"]),
    ],
)
def test_items_are_split_where_a_user_would_split_them(text: str, items: list[str]) -> None:
    assert [item for _, item in fault_items(text)] == items


def test_a_fault_time_written_with_a_space_is_taken_by_the_api_and_the_command(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # '2' was told it "needs a unit: write it as e.g. '2 s'", which is what was written
    assert split_faults("motor_stall:bend_1_drive@2 s, delay=20 ms") == (
        ["motor_stall:bend_1_drive@2 s"],
        "delay=20 ms",
    )
    result = pirate_bt.simulate_tree(
        "straight", params={"distance": "0.2 m"}, faults="board_reset:26@0.5 s+0.2 s"
    )
    # taken, at 0.5 s: board 26 rebooting left bend_3's readings stale
    assert not result.succeeded and "stale data: bend_3_angle" in result.why, result.why
    code = main(["run", "straight", "--param", "distance=0.2 m", "-q", "--faults", "bogus@2 s"])
    assert code == 2
    err = capsys.readouterr().err
    assert err.startswith("pirate-bt: --faults:1:1: ") and "needs a unit" not in err, err
