"""A PICO board whose IMU stops answering (probe 17): the reply's STALE, end to end.

Until 2026-11-30 the reference PICO firmware kept answering with the IMU's last
angles after the IMU stopped answering, with nothing in the reply's status; the bridge
marked them fresh, so the host's freshness check never saw it and believed a frozen
pitch (a robot could release both clamps in a riser). Now (docs/board-bus.md, status
bit 3 ``STALE``) the board says so 50 ms after the last good read, the bridge leaves the
board's sensor channels not fresh (its drive's feedback stays fresh), and the host's
freshness rule reports the IMU stale.

The PICO firmware's and the bridge firmware's own C (their host builds) talk here: the
bridge's requests to board 24 go to the PICO, the PICO's replies back on the line.
"""

from __future__ import annotations

import shutil
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))

from board_bus_support import (
    BOARD_INPUTS,
    BOARDS,
    EXCHANGE,
    KEEP,
    ROBOT,
    BusMaster,
    Pico,
    _layout_header,
    _make,
    _wait,
    doc_request,
    doc_take_reply,
    wire_with_crc,
)
from firmware_chain_support import PicoAlone, missing_chain

from pirate_bt.pipes import load_network
from pirate_bt.robot.state import RobotState, StateBuilder
from pirate_bt.safety.checks import stale_channels
from pirate_bt.sim.boardbus import STATUS_STALE, BoardBus
from pirate_bt.sim.model import PipeRobotModel

STALE = 0x08
IMU_BOARD = 24
IMU = [c.index for c in ROBOT.state_channels() if c.name.startswith("imu.")]
DRIVE = [c.index for c in ROBOT.state_channels() if c.board == IMU_BOARD and c.index not in IMU]
STATE_KIND = 0x82


@pytest.fixture(scope="module")
def builds(tmp_path_factory: pytest.TempPathFactory) -> Path:
    if shutil.which("cc") is None or shutil.which("make") is None:
        pytest.skip("no host C compiler (cc) or make: the firmwares' C cannot be built")
    build = tmp_path_factory.mktemp("probe17-imu")
    _layout_header(build)
    for job in [_make("pico", build), _make("piratebay", build)]:
        _wait(job)
    return build


class Chain:
    """The bridge's host build; board 24 is the PICO firmware's host build."""

    def __init__(self, build: Path, workdir: Path) -> None:
        self.master = BusMaster(build / "libpiratebay_host.so", workdir)
        self.pico = Pico(build / "libpico_host.so", workdir)
        self.pico.boot(IMU_BOARD)
        self.master.behaviour[IMU_BOARD] = self._pico_answers
        self.replies: list[tuple[int, list[int]]] = []
        self.states = StateBuilder(ROBOT)
        self.state: RobotState | None = None
        self.fresh = 0
        self.values: list[int] = []
        self.status: list[int] = []

    def _pico_answers(self, body: bytes, reply: bytes) -> list[tuple[int, bytes]]:
        now = self.master.now_us
        self.pico.run_to(now)
        self.pico.write(wire_with_crc(body))
        self.pico.run_to(now + 200)
        got = self.pico.read()
        taken = doc_take_reply(IMU_BOARD, got.rstrip(b"\x00"))
        if taken is not None:
            self.replies.append(taken)
        return [(200, got)] if got else []

    def run(self, ms: int) -> None:
        """Let `ms` pass, 10 ms at a time, the host building its state from each STATE."""
        for _ in range(ms // 10):
            self.master.run(10)
            now_s = self.master.now_us / 1e6
            for f in self.master.host.read():
                if f.kind != STATE_KIND:
                    continue
                _, fresh, _, self.status, values = self.master.host.state(f)
                raw = [v if fresh >> i & 1 else None for i, v in enumerate(values)]
                self.state = self.states.build(raw, now_s, self.state)
                self.fresh, self.values = fresh, values

    def fresh_of(self, channels: list[int]) -> list[bool]:
        return [bool(self.fresh >> c & 1) for c in channels]

    def host_stale(self) -> list[str]:
        assert self.state is not None
        now_s = self.master.now_us / 1e6
        return [n for n, _ in stale_channels(ROBOT, self.state, ("imu.pitch",), now_s)]


@pytest.fixture()
def chain(builds: Path, tmp_path: Path) -> Iterator[Chain]:
    yield Chain(builds, tmp_path)


def test_an_imu_that_stops_answering_goes_stale_at_the_host_and_comes_back(
    chain: Chain,
) -> None:
    chain.run(100)
    assert chain.replies and all(not s & STALE for s, _ in chain.replies)
    assert chain.fresh_of(IMU + DRIVE) == [True] * 5
    assert chain.host_stale() == []
    good = [chain.values[c] for c in IMU]
    assert good != [0, 0, 0]  # the vectors' angles, read through the IMU

    chain.pico.lib.pk_imu_silent(1)
    chain.pico.lib.pk_imu(0, 0, 0)  # whatever the IMU would say now, nobody reads it
    chain.run(30)
    assert chain.fresh_of(IMU) == [True] * 3  # within its 50 ms the board says nothing
    chain.run(50)
    # the board says STALE, with the last good angles; the bridge leaves the IMU's
    # channels not fresh, its drive's speed and current fresh
    status, channels = chain.replies[-1]
    assert status & STALE and channels[:3] == good
    assert chain.fresh_of(IMU) == [False] * 3 and chain.fresh_of(DRIVE) == [True] * 2
    chain.run(100)
    assert chain.host_stale() == ["imu.pitch"]  # the supervisor's freshness rule sees it

    chain.pico.lib.pk_imu(*BOARD_INPUTS[IMU_BOARD][0]["imu"])
    chain.pico.lib.pk_imu_silent(0)  # it answers again
    chain.run(30)
    assert not chain.replies[-1][0] & STALE
    assert chain.fresh_of(IMU + DRIVE) == [True] * 5
    assert [chain.values[c] for c in IMU] == good
    assert chain.host_stale() == []


def test_an_old_style_reply_is_taken_as_before_and_stale_only_clears_sensors(
    chain: Chain,
) -> None:
    """Bit 3 clear: every channel fresh, as before; bit 3 set (a board that says STALE):
    the board's sensors not fresh, its motors' feedback fresh, the values taken."""
    master = chain.master
    for status, want_imu in ((0, True), (STALE, False), (0x01 | STALE, False), (0x07, True)):
        reply = _reply(IMU_BOARD, status, [11, 22, 33, 0, 40])
        master.behaviour[IMU_BOARD] = lambda body, r, reply=reply: [(150, reply)]
        chain.run(30)
        assert chain.fresh_of(IMU) == [want_imu] * 3, status
        assert chain.fresh_of(DRIVE) == [True] * 2, status
        assert [chain.values[c] for c in IMU + DRIVE] == [11, 22, 33, 0, 40]
        others = [c.index for c in ROBOT.state_channels() if c.board != IMU_BOARD]
        assert all(chain.fresh_of(others)), status
        status_nibble = chain.status[BOARDS.index(IMU_BOARD)]
        assert status_nibble & 0x1 and not status_nibble & 0x4  # ONLINE, not TIMEOUT


def test_the_python_boards_say_stale_like_the_pico() -> None:
    bus = BoardBus(PipeRobotModel(ROBOT, load_network("straight")))
    before = bus.replies()[IMU_BOARD]
    assert not doc_take_reply(IMU_BOARD, before[:-1])[0] & STATUS_STALE
    bus.set_stale(IMU_BOARD)
    bus.model.step(0.5)
    status, channels = doc_take_reply(IMU_BOARD, bus.replies()[IMU_BOARD][:-1])
    assert status & STATUS_STALE == STALE
    assert channels[:3] == doc_take_reply(IMU_BOARD, before[:-1])[1][:3]
    bus.set_stale(IMU_BOARD, False)
    assert not doc_take_reply(IMU_BOARD, bus.replies()[IMU_BOARD][:-1])[0] & STATUS_STALE


def _reply(board: int, status: int, channels: list[int]) -> bytes:
    from board_bus_support import _reply as page_reply

    return page_reply(board, status, channels)


@pytest.mark.skipif(missing_chain() is not None, reason=str(missing_chain()))
def test_the_avr_build_says_stale_when_its_imu_stops_answering_in_simavr() -> None:
    """The AVR build itself (hal_avr.c's TWI, which kept its 'valid' flag for ever), in
    simavr with Python the master: the IMU on TWI stops acknowledging its address, the
    reply says STALE after 50 ms with the last good angles, and not once it answers."""
    inputs, channels = BOARD_INPUTS[IMU_BOARD]
    request = doc_request(IMU_BOARD, EXCHANGE, [(KEEP, 0)])
    pico = PicoAlone(IMU_BOARD)
    statuses: list[tuple[int, int, list[int]]] = []
    try:
        t_ms = 0

        def poll(until_ms: int, imu: list[int]) -> None:
            nonlocal t_ms
            while t_ms < until_ms:
                t_ms += 10
                pico.run_to(t_ms / 1000, {**inputs, "imu": imu})
                heard = pico.run_to(t_ms / 1000 + 0.0006, {**inputs, "imu": imu}, request)
                taken = doc_take_reply(IMU_BOARD, heard.rstrip(b"\x00").lstrip(b"\x00"))
                assert taken is not None, (t_ms, heard.hex())
                statuses.append((t_ms, taken[0], taken[1]))

        poll(100, inputs["imu"])
        assert all(not s & STALE for _, s, _ in statuses)
        assert statuses[-1][2][:3] == channels[:3]
        pico._send("I", bytes((0, 0)))  # the IMU answers nothing from now on
        poll(140, [0, 0, 0])
        assert not statuses[-1][1] & STALE  # within its 50 ms
        poll(200, [0, 0, 0])
        assert statuses[-1][1] & STALE and statuses[-1][2][:3] == channels[:3]
        pico._send("I", bytes((0, 1)))
        poll(230, inputs["imu"])
        assert not statuses[-1][1] & STALE and statuses[-1][2][:3] == channels[:3]
    finally:
        pico.close()
