"""A simulator fault with its ``@`` but a part missing said "bad fault ...; e.g.
link_loss@5s+1s" (an example of another kind), and one without its target asked for
``KIND:NAME@AT`` where a board id is meant. Each now says what it lacks, with an
example of its own kind (the wording of ``api/fault_text.py``)."""

from __future__ import annotations

import pytest

from pirate_bt.cli import main
from pirate_bt.errors import InputError
from pirate_bt.sim.faults import parse_fault


@pytest.mark.parametrize(
    ("text", "words"),
    [
        (
            "board_reset:22@",
            "simulator fault 'board_reset:22@' lacks its time: write board_reset:22@AT"
            "[+DURATION], e.g. board_reset:22@5s",
        ),
        (
            "board_reset:@5s",
            "simulator fault 'board_reset:@5s' lacks its target: write"
            " board_reset:BOARD@AT[+DURATION], e.g. board_reset:22@5s",
        ),
        (
            "motor_stall:@5s",
            "simulator fault 'motor_stall:@5s' lacks its target: write"
            " motor_stall:NAME@AT[+DURATION], e.g. motor_stall:bend_1_drive@5s",
        ),
        (
            "board_reset@5s",
            "fault board_reset needs a target: write board_reset:BOARD@AT[+DURATION],"
            " e.g. board_reset:22@5s",
        ),
        (
            "board_fault:@",
            "simulator fault 'board_fault:@' lacks its target and its time: write"
            " board_fault:BOARD@AT[+DURATION], e.g. board_fault:22@5s",
        ),
        (
            "link_loss@5s+",
            "simulator fault 'link_loss@5s+' lacks its duration after '+': write"
            " link_loss@AT+DURATION, e.g. link_loss@5s+1s",
        ),
    ],
)
def test_a_fault_missing_a_part_says_which_with_its_own_example(text: str, words: str) -> None:
    with pytest.raises(InputError) as caught:
        parse_fault(text)
    assert str(caught.value) == f"faults: {words}"


def test_the_command_line_places_it_and_exits_2(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["run", "straight", "--faults", "drop=0.01,board_reset:22@"]) == 2
    err = capsys.readouterr().err
    assert err == (
        "pirate-bt: --faults:1:11: simulator fault 'board_reset:22@' lacks its time: write"
        " board_reset:22@AT[+DURATION], e.g. board_reset:22@5s\n"
    )
