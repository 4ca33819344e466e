"""A board or motor fault written without its time is told what it lacks, with an example.

An item of ``faults`` without an ``@`` is taken for a link fault (KEY=VALUE), so
``board_reset:22`` was told "link fault 'board_reset:22' is not key=value".
"""

from __future__ import annotations

import pytest

from pirate_bt.api.fault_text import split_faults
from pirate_bt.cli import main
from pirate_bt.errors import InputError


@pytest.mark.parametrize(
    ("item", "words"),
    [
        (
            "board_reset:22",
            "simulator fault 'board_reset:22' lacks its time: write board_reset:22@AT"
            "[+DURATION], e.g. board_reset:22@5s",
        ),
        (
            "motor_stall:bend_1_drive+2s",
            "simulator fault 'motor_stall:bend_1_drive+2s' lacks its time: write"
            " motor_stall:bend_1_drive@AT+2s, e.g. motor_stall:bend_1_drive@5s+2s",
        ),
        (
            "board_fault",
            "simulator fault 'board_fault' lacks its target and its time: write"
            " board_fault:BOARD@AT[+DURATION], e.g. board_fault:22@5s",
        ),
        (
            "link_loss+1s",
            "simulator fault 'link_loss+1s' lacks its time: write link_loss@AT+1s,"
            " e.g. link_loss@5s+1s",
        ),
        (
            "board_reset=22",
            "'board_reset=22' is a simulator fault, not a link fault (KEY=VALUE): write"
            " board_reset:BOARD@AT[+DURATION], e.g. board_reset:22@5s",
        ),
    ],
)
def test_a_simulator_fault_without_its_time_says_what_it_lacks(item: str, words: str) -> None:
    with pytest.raises(InputError) as caught:
        split_faults(f"drop=0.01,{item}")
    assert str(caught.value) == f"faults: {words}"


def test_the_command_line_places_it_at_its_column(capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["run", "straight", "--faults", "drop=0.01 board_reset:22"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2
    assert err == [
        "pirate-bt: --faults:1:11: simulator fault 'board_reset:22' lacks its time: write"
        " board_reset:22@AT[+DURATION], e.g. board_reset:22@5s"
    ]


@pytest.mark.parametrize(
    ("item", "words"),
    [
        ("bogus", "link fault 'bogus' is not key=value (drop=0.05)"),
        ("drop", "link fault 'drop' is not key=value (drop=0.05)"),
        ("Board_reset:22", "link fault 'Board_reset:22' is not key=value (drop=0.05)"),
    ],
)
def test_a_link_fault_that_is_no_simulator_fault_is_told_as_before(item: str, words: str) -> None:
    with pytest.raises(InputError) as caught:
        split_faults(item)
    assert str(caught.value) == f"faults: {words}"
