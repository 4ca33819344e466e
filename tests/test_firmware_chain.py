"""The whole embedded chain in simavr: the bridge and nine PICO boards, each its own ELF.

The bridge firmware on a simulated ATmega2560 and the reference PICO firmware on nine
simulated ATmega328ps, on one simulated RS485 line, with the pipe physics behind the
boards' pins (``pirate_bt.sim.chain``, ``firmware/simavr/chain.c``), in virtual time:
the host's own link and supervisor drive it on a simulated clock, as they drive a
robot. Through it: the straight and the bend PAB succeed; a host ``ESTOP`` and the
hardware e-stop input stop every drive within their bounds with the clamps held; a
bridge killed mid-drive leaves every board to stop on its own after its silence time,
the clamps still held. And the PICO's AVR build alone, Python the master on its line,
passes the board bus's shared vectors byte for byte. Skipped, with the reason, where
the AVR toolchain or libsimavr is missing.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from firmware_chain_support import (
    PicoAlone,
    build_chain,
    missing_chain,
    open_chain,
    stop_scenario,
)

import pirate_bt

needs_chain = pytest.mark.skipif(
    missing_chain() is not None, reason=f"the chain in simavr: {missing_chain()}"
)
RUN, BRAKE = 2, 1
CLAMP_DUTY = round(0.7 / 1.023 * 255)  # the clamp torque of firmware_chain_support


VECTORS = json.loads((Path(__file__).parent / "data" / "board_bus_vectors.json").read_text())
SHORT_BEND = Path(__file__).parent / "data" / "networks" / "bend-right-short.yaml"


@needs_chain
@pytest.mark.parametrize("sequence", VECTORS["sequences"], ids=lambda s: s["name"])
def test_the_pico_elf_passes_the_board_bus_vectors_in_simavr(sequence: dict[str, Any]) -> None:
    """The AVR build itself, Python the master on its line: the bytes of every reply."""
    board = sequence["board"]
    n_motors = len(next(s for s in sequence["steps"])["expect_motors"])
    pico = PicoAlone(board)
    try:
        for number, step in enumerate(sequence["steps"], 1):
            where = f"{sequence['name']} step {number}"
            at_s = step["at_ms"] / 1000
            heard = pico.run_to(at_s, step["pico_inputs"])
            send = bytes.fromhex(step["send_hex"]) if step["send_hex"] else b""
            # the request (0.1 ms at 1 Mbaud), the board's turnaround, its reply
            heard += pico.run_to(at_s + 0.0006, step["pico_inputs"], send)
            assert (heard.hex() or None) == step["expect_reply_hex"], where
            assert pico.motors(n_motors) == step["expect_motors"], where
    finally:
        pico.close()


@needs_chain
def test_every_board_answers_on_one_line_without_collisions() -> None:
    with open_chain() as (chain, _clock):
        chain.advance_to(0.5)
        figures = chain.figures()
    for board in chain.physics.boards:
        assert figures[f"pico_{board}_exchanges"] >= 45, board  # one poll a period
        assert figures[f"pico_{board}_bad_frames"] == 0, board
        assert figures[f"pico_{board}_own_stops"] == 0, board
    assert figures["line_collisions"] == 0 and figures["line_truncated"] == 0
    assert figures["line_echo"] == 0  # DE and /RE: nobody hears itself
    # nine exchanges fit a state period with room to spare; the longest cycle is the
    # first, with the boot's STOP to every board ahead of its polls
    assert figures["bus_cycle_us_mean"] < 7_000 and figures["bus_cycle_us_max"] < 12_000
    assert figures["bridge_bus_framing_errors"] == 0


@needs_chain
@pytest.mark.slow
@pytest.mark.parametrize(
    ("network", "tree", "params"),
    [
        # a quarter metre: hold, then 3 s of driving (6.2 s of AVR time in all, 9.3 for
        # half a metre): the same hold and drive through the same boards, 300 polls a board
        pytest.param("straight", "straight", {"distance": "0.25m"}, id="straight"),
        # bend-right with a shorter approach (the file says why): a third less AVR time
        pytest.param(str(SHORT_BEND), "bend", {"roll": "90deg"}, id="bend-right"),
    ],
)
def test_a_pab_succeeds_through_the_whole_chain(
    network: str, tree: str, params: dict[str, str]
) -> None:
    build_chain()
    # the public door, as a planner would write it (docs/firmware-sim.md)
    with pirate_bt.connect(f"firmware:{network}") as robot:
        result = robot.run(tree, params=params, max_time="120 s")
        figures = robot.simulator.figures()
        truth = robot.simulator.truth()
        counters = robot.simulator.counters()
    assert result.succeeded, result.summary()
    assert "firmware chain in simavr" in result.summary()
    assert not counters.violations
    # No damage at all: the PICO's position loop (10-bit ADC, 0.5 degree dead band)
    # settles within half a degree of its target, and MoveFrontClear aims past the
    # clear angle by the angle tolerance, so the front module ends clear
    assert not counters.damage, counters.damage
    assert truth.front_m > 0.5
    assert figures["line_collisions"] == 0
    assert all(figures[f"pico_{b}_own_stops"] == 0 for b in robot.simulator.chain.physics.boards)


@needs_chain
@pytest.mark.parametrize(
    ("cause", "bound_s"),
    [
        # the exchange in flight, a STOP to nine boards at 1 Mbaud, the last one applied
        pytest.param("host", 0.005, id="host-estop"),
        # the same after two 1 ms samples of the open contact
        pytest.param("input", 0.007, id="estop-input"),
    ],
)
def test_an_estop_stops_every_drive_and_the_clamps_hold(cause: str, bound_s: float) -> None:
    scenario = stop_scenario(cause)
    assert len(scenario.running_before) == 6  # every drive was running
    assert scenario.times.all_stopped_s < bound_s, scenario.times
    for joint, (drive, duty) in scenario.joints_after.items():
        assert drive == RUN and abs(duty - CLAMP_DUTY) <= 1, joint  # still clamping
    assert all(scenario.figures[f"pico_{b}_own_stops"] == 0 for b in (22, 25, 28))
    if cause == "input":
        assert scenario.figures["bridge_estop_input_trips"] == 1


@needs_chain
def test_killing_the_bridge_makes_every_board_stop_on_its_own_with_clamps_held() -> None:
    scenario = stop_scenario("master_silent")
    assert len(scenario.running_before) == 6
    # each board stops 100 ms after the last poll it heard (a poll every 10 ms)
    assert 0.09 <= scenario.times.all_stopped_s <= 0.102, scenario.times
    for board in (20, 21, 22, 23, 24, 25, 26, 27, 28):
        assert scenario.figures[f"pico_{board}_own_stop"] == 1, board
    for joint, (drive, duty) in scenario.joints_after.items():
        assert drive == RUN and abs(duty - CLAMP_DUTY) <= 1, joint  # never released
