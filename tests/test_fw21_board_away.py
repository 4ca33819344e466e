"""Probe 21: a PICO board that stops answering the bridge for longer than its own silence time.

docs/board-bus.md: a board that hears no master for 100 ms stops itself, and on
``OWN_STOP`` the bridge stops the whole robot ("a part of the robot has stopped on its
own, so the rest stops too"). A board that lost its power, or whose replies no longer
reach the bridge, says no ``OWN_STOP``: it is only missing. The bridge firmware kept the
rest of the robot driving however long it was missing, and when it answered again handed
it its old setpoints: a drive that came back restarted alone, though the host had
stopped the others meanwhile (the host sends a board in ``TIMEOUT`` keep, and the bridge
refuses anything else for it). Now a board not heard for 100 ms is taken as stopped on
its own, as for ``OWN_STOP``.

The firmware's own C, built for this machine (``tests/firmware_host.py``), in virtual
time; what the motors are told is read off the board bus.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from cleanroom_peer import HEARTBEAT, KEEP, frame
from firmware_chain_support import missing_chain, open_chain
from firmware_host import build_host_library
from test_fw21_cleanroom_firmware import (
    LAYOUT,
    PERIOD_S,
    PWM,
    ROBOT,
    VELOCITY,
    FirmwarePeer,
    braked,
    bulk,
    drive_entries,
    running,
)
from test_fw21_flood import ChainHost

BOARDS = sorted(ROBOT.board_ids())
AWAY = 24  # the rotational drive A and the IMU
BOARD_SILENCE_S = 0.1  # docs/board-bus.md, board-side timeout


@pytest.fixture(scope="module")
def library(tmp_path_factory: pytest.TempPathFactory) -> Path:
    try:
        return build_host_library(tmp_path_factory.mktemp("fw21-away"))
    except RuntimeError as exc:
        if "no host C compiler" in str(exc):
            pytest.skip(f"{exc}: the firmware cannot be built for the host")
        raise


@pytest.fixture
def peer(library: Path, tmp_path: Path) -> Iterator[FirmwarePeer]:
    under_test = FirmwarePeer(library, tmp_path)
    try:
        yield under_test
    finally:
        under_test.close()


class Host:
    """A host that keeps the link alive (a heartbeat every 20 ms) while time passes."""

    def __init__(self, peer: FirmwarePeer) -> None:
        self.peer = peer
        self.seq = 1000

    def wait(self, seconds: float) -> None:
        for _ in range(round(seconds / 0.02)):
            self.seq += 1
            self.peer.step(frame(HEARTBEAT, self.seq), dt=0.02)


def set_board(peer: FirmwarePeer, board: int, answers: bool) -> None:
    peer.bridge._lib.fw_board(BOARDS.index(board), int(answers), 0)


def bends_told(peer: FirmwarePeer) -> dict[tuple[int, int], tuple[int, int, int]]:
    return {
        (b, s): peer.told[(b, s)]
        for b, s, role, _ in LAYOUT.motors
        if (b, s) in peer.told and role == "bend"
    }


def test_a_board_back_after_its_silence_time_does_not_restart_its_drive_alone(
    peer: FirmwarePeer,
) -> None:
    running(peer, 400)
    host = Host(peer)
    set_board(peer, AWAY, False)
    host.wait(0.04)
    # the host stops the drives; the board away is in TIMEOUT: its entries go as keep
    stop = [
        (KEEP, 0) if board == AWAY else entry
        for (board, _, _, _), entry in zip(LAYOUT.motors, drive_entries(0), strict=True)
    ]
    assert peer.step(bulk(4, stop)) == []
    host.wait(0.3)
    set_board(peer, AWAY, True)  # it answers again (it lost its power, say)
    host.wait(0.1)
    assert braked(peer), peer.drives()


def test_a_board_away_for_good_stops_the_robot_and_keeps_the_clamps(peer: FirmwarePeer) -> None:
    running(peer, 400)
    host = Host(peer)
    bends = bends_told(peer)
    set_board(peer, AWAY, False)
    host.wait(BOARD_SILENCE_S + 6 * PERIOD_S)
    assert braked(peer), peer.drives()
    assert bends_told(peer) == bends  # no bend joint was told anything: the clamps hold
    # once: the host may drive again (the board stays away); nothing stops it a second time
    entries = [
        (KEEP, 0) if board == AWAY else entry
        for (board, _, _, _), entry in zip(LAYOUT.motors, drive_entries(300), strict=True)
    ]
    assert peer.step(bulk(5, entries)) == []
    host.wait(0.3)
    moving = {key: told for key, told in peer.drives().items() if key[0] != AWAY}
    assert set(moving.values()) == {(VELOCITY, 300)}


def test_a_board_that_misses_a_few_polls_stops_nothing(peer: FirmwarePeer) -> None:
    running(peer, 400)
    host = Host(peer)
    set_board(peer, AWAY, False)
    host.wait(0.04)  # a few lost replies: TIMEOUT for a period or two
    set_board(peer, AWAY, True)
    host.wait(0.2)
    assert set(peer.drives().values()) == {(VELOCITY, 400)}, peer.drives()
    assert PWM not in {mode for mode, _ in peer.drives().values()}


# -- through the whole chain: the reference PICO's AVR build loses its power --------------

RUN, BRAKE = 2, 1


@pytest.mark.skipif(missing_chain() is not None, reason=f"the chain in simavr: {missing_chain()}")
def test_a_pico_that_loses_its_power_mid_drive_comes_back_braked_through_the_chain() -> None:
    """The bridge ELF and nine PICO ELFs in simavr: board 24 (the rotational drive A)
    loses its power while every drive runs; the host stops the others (board 24's
    entries keep); board 24 boots again. Before, its drive restarted alone at the
    bridge's old setpoint (duty 100 while every other drive was braked)."""
    with open_chain() as (chain, _clock):
        host = ChainHost(chain)
        host.session()
        host.step(bulk(3, drive_entries(400)), 0.1)
        drives = [(b, s) for b, s, role, _ in LAYOUT.motors if role == "drive"]
        assert {chain.outputs[key][0] for key in drives} == {RUN}
        chain.power_board(AWAY, False)
        beat = iter(range(100, 200))
        for _ in range(3):
            host.step(frame(HEARTBEAT, next(beat)), 0.02)
        stop = [
            (KEEP, 0) if board == AWAY else entry
            for (board, _, _, _), entry in zip(LAYOUT.motors, drive_entries(0), strict=True)
        ]
        host.step(bulk(4, stop), 0.02)
        for _ in range(12):
            host.step(frame(HEARTBEAT, next(beat)), 0.02)
        assert chain.outputs[(AWAY, 1)][0] == 0  # no power: limp
        chain.power_board(AWAY, True)
        for _ in range(10):
            host.step(frame(HEARTBEAT, next(beat)), 0.02)
        assert {key: chain.outputs[key][0] for key in drives} == dict.fromkeys(drives, BRAKE)
        assert host.errors == []
