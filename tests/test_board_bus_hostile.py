"""Hostile bytes on the board bus, and a master and a board written from docs/board-bus.md.

Three implementations receive board-bus bytes: the Python boards
(:class:`pirate_bt.sim.boardbus.BoardBus`), the reference PICO firmware's receiver
(``firmware/pico/bus.c``, its host build) and the bridge firmware's bus master
(``firmware/piratebay/board_bus.c`` and ``poller.c``, its host build), which receives
the boards' replies. Here they get random bytes, truncated and overlong frames, frames
to other or no boards, CRC-valid nonsense, and replies from the wrong board, late,
twice, never, or longer than any buffer. Nothing may crash or overrun (the C is also
built with ``-fsanitize=address,undefined`` and run on random streams in a child
process with the runtime preloaded), no motor may move on a frame the page says to
ignore, the boards must answer byte for byte alike, and the bridge must report a
silent or confused board as the page says (board status, counters, ``BUS_FAULT``).

The independent end (:class:`DocBoard`, :func:`doc_request`, :func:`doc_take_reply`)
is written from docs/board-bus.md alone: COBS, CRC-16/XMODEM and the frame checks
are spelled out here, not imported; only the robot's layout (its boards, motors,
modes, ranges and channels) comes from the robot description, as the page says.
"""

from __future__ import annotations

import ctypes
import os
import random
import shutil
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from board_bus_support import (
    ASAN,
    B_FAULT,
    BAD_REPLIES,
    BOARD_INPUTS,
    BOARDS,
    CHANNELS_22,
    EXCHANGE,
    F_BUS_FAULT,
    GOOD_REPLIES,
    KEEP,
    LAYOUT,
    ONLINE,
    OWN_STOP,
    REPLY,
    ROBOT,
    STOP,
    TIMEOUT,
    TURNAROUND_US,
    VECTORS,
    Builds,
    BusMaster,
    DocBoard,
    Pico,
    Splitter,
    _layout_header,
    _make,
    _once,
    _random_reply,
    _slots,
    _wait,
    doc_request,
    doc_take_reply,
    hostile_stream,
)

from pirate_bt.pipes import load_network
from pirate_bt.sim.boardbus import BoardBus
from pirate_bt.sim.model import PipeRobotModel

pytestmark = pytest.mark.xdist_group("board_bus_hostile")


@pytest.fixture(scope="module")
def builds(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Builds]:
    """Both host libraries, plain (bounds checks that trap), then with ASan and UBSan in
    the background."""
    if shutil.which("cc") is None or shutil.which("make") is None:
        pytest.skip("no host C compiler (cc) or make: the firmwares' C cannot be built")
    plain = tmp_path_factory.mktemp("bus-plain")
    asan = tmp_path_factory.mktemp("bus-asan")
    for build in (plain, asan):
        _layout_header(build)
    for job in [_make("pico", plain), _make("piratebay", plain)]:
        _wait(job)
    asan_jobs = [  # while the tests run (the last one needs them)
        _make("piratebay", asan, "HOST_OPT=-O0", f"HOST_SANITIZE={ASAN}"),
        _make("pico", asan, "HOST_OPT=-O0", f"HOST_SANITIZE={ASAN}"),
    ]
    result = Builds(plain, asan, asan_jobs)
    yield result
    for job in result.asan_jobs:
        job.communicate()


# -- hostile streams to a board ---------------------------------------------------------------


@pytest.fixture()
def pico(builds: Builds, tmp_path: Path) -> Pico:
    return Pico(builds.plain / "libpico_host.so", tmp_path)


def _three_boards(pico: Pico, board: int) -> tuple[Splitter, DocBoard]:
    pico.boot(board)
    pico.run_to(5000)  # the sensors' first readings
    bus = BoardBus(PipeRobotModel(ROBOT, load_network("straight")))
    channels = BOARD_INPUTS[board][1]
    bus.set_readings(board, channels)
    return Splitter(bus, board), DocBoard(LAYOUT[board], channels)


@pytest.mark.parametrize("board", [22, 24, 25, 28])
def test_the_three_boards_answer_hostile_streams_alike(pico: Pico, board: int) -> None:
    """PICO firmware, Python boards and the page's board: the same replies, byte for
    byte, and the same setpoints, after every piece of 12 random hostile streams; and a
    piece that holds no good frame to the board changes no setpoint of the PICO."""
    n = len(LAYOUT[board].motors)
    python, doc = _three_boards(pico, board)
    t_us = 5500
    answered = ignored = 0
    for seed in range(12):
        rng = random.Random(seed)
        stream = hostile_stream(rng, board)
        if rng.random() < 0.2:
            stream = b""  # and now and then the master falls silent
        pieces = _slots(stream) + [b""] * (rng.choice([0, 0, 0, 120]))
        for number, piece in enumerate(pieces):
            where = f"seed {seed} piece {number}: {piece.hex()}"
            before = pico.motors(n)
            own_before = doc.own_stop
            heard_before = doc.heard_s
            pico.run_to(t_us)
            doc.advance(t_us / 1e6)
            pico.write(piece)
            pico.run_to(t_us + 400)
            got = pico.read()
            assert python.receive(t_us / 1e6, piece) == got, where
            assert doc.receive(piece) == got, where
            after = pico.motors(n)
            assert python.motors() == after == doc.state, where
            if doc.heard_s == heard_before and doc.own_stop == own_before:
                assert after == before, where  # nothing good arrived: nothing moves
                ignored += 1
            else:
                answered += 1
            t_us += 1000
    assert answered > 15 and ignored > 150  # the streams hold both kinds


@pytest.fixture()
def master(builds: Builds, tmp_path: Path) -> BusMaster:
    return BusMaster(builds.plain / "libpiratebay_host.so", tmp_path)


def test_the_bridge_polls_the_page_boards(master: BusMaster) -> None:
    """The page's boards, written here, are the bridge's boards: every channel fresh,
    the values theirs, no error counted."""
    master.run(35)
    fresh, flags, status, values = master.state()
    assert all(master.fresh(b, fresh) for b in BOARDS) and not flags & F_BUS_FAULT
    assert all(s & ONLINE for s in status)
    for c in ROBOT.state_channels():
        board = master.boards[c.board]
        first = min(x.index for x in ROBOT.state_channels() if x.board == c.board)
        assert values[c.index] == board.channels[c.index - first]
    assert set(master.counters().values()) == {(0, 0, 0)}


def _period_report(master: BusMaster) -> dict[str, Any]:
    fresh, flags, status, _ = master.state()
    return {"fresh": fresh, "flags": flags, "status": status, "counters": master.counters()}


@pytest.mark.parametrize("name", sorted(BAD_REPLIES))
def test_a_bad_reply_is_refused_counted_retried_and_reported(master: BusMaster, name: str) -> None:
    """The bridge and the page's master judge the reply alike; a bad one counts in the
    board's crc_errors (never timeouts), is retried once a period, and leaves the board
    in TIMEOUT, its channels not fresh; the other boards go on as before."""
    data = BAD_REPLIES[name]
    assert doc_take_reply(22, data[:-1].lstrip(b"\x00")) is None
    master.behaviour[22] = lambda body, reply: [(TURNAROUND_US, data)]
    master.run(45)
    report = _period_report(master)
    timeouts, crc, retries = report["counters"][22]
    assert timeouts == 0 and crc >= 4 and retries >= 2, report
    assert report["status"][BOARDS.index(22)] & (ONLINE | TIMEOUT) == TIMEOUT
    assert not master.fresh(22, report["fresh"])
    for other in BOARDS:
        if other != 22:
            assert master.fresh(other, report["fresh"]) and report["counters"][other] == (0, 0, 0)
    assert not report["flags"] & F_BUS_FAULT


@pytest.mark.parametrize("name", sorted(GOOD_REPLIES))
def test_a_good_reply_is_taken_by_both_masters(master: BusMaster, name: str) -> None:
    data = GOOD_REPLIES[name]
    taken = doc_take_reply(22, data[:-1].lstrip(b"\x00"))
    assert taken is not None
    master.behaviour[22] = lambda body, reply: [(TURNAROUND_US, data)]
    master.run(25)
    fresh, _, status, values = master.state()
    first = min(c.index for c in ROBOT.state_channels() if c.board == 22)
    # status bit 3, STALE: the board's sensors (angle, spring) not fresh, its drive's
    # feedback fresh; a reply without it: every channel fresh
    sensors = 2 if taken[0] & 0x08 else 0
    assert [fresh >> c & 1 for c in range(first, first + 4)] == [0] * sensors + [1] * (4 - sensors)
    assert status[BOARDS.index(22)] & (ONLINE | B_FAULT) == ONLINE
    assert values[first : first + 4] == taken[1]
    assert master.counters()[22] == (0, 0, 0)


def test_a_board_that_never_answers_is_in_timeout_and_counted(master: BusMaster) -> None:
    master.behaviour[22] = lambda body, reply: []
    master.run(45)
    report = _period_report(master)
    timeouts, crc, retries = report["counters"][22]
    assert timeouts >= 8 and crc == 0 and retries >= 4
    assert report["status"][BOARDS.index(22)] & (ONLINE | TIMEOUT) == TIMEOUT
    assert all(master.fresh(b, report["fresh"]) for b in BOARDS if b != 22)
    assert not report["flags"] & F_BUS_FAULT


def test_a_late_reply_is_a_timeout_and_never_charged_to_the_next_board(master: BusMaster) -> None:
    """Answered 1.7 ms after each request (the bridge gives up at 1.5 ms): a timeout for
    this board; its late bytes end before the retry or the next request (the quiet
    time), so no other board's reply is spoiled."""
    master.behaviour[22] = lambda body, reply: [(1700, reply)]
    master.run(45)
    report = _period_report(master)
    timeouts, crc, _ = report["counters"][22]
    assert timeouts >= 8 and crc == 0
    assert report["status"][BOARDS.index(22)] & TIMEOUT
    assert all(report["counters"][b] == (0, 0, 0) for b in BOARDS if b != 22)
    assert all(master.fresh(b, report["fresh"]) for b in BOARDS if b != 22)


def test_a_reply_sent_twice_is_taken_once(master: BusMaster) -> None:
    """The second copy lands in the next board's exchange: that one is a bad reply (the
    page counts it for the board being polled), retried at once, so every board is
    still fresh and ONLINE each period."""
    master.behaviour[22] = lambda body, reply: [
        (TURNAROUND_US, reply),
        (TURNAROUND_US + 10 * len(reply) + 30, reply),
    ]
    master.run(45)
    report = _period_report(master)
    assert all(master.fresh(b, report["fresh"]) for b in BOARDS), report
    assert all(s & (ONLINE | TIMEOUT) == ONLINE for s in report["status"]), report
    assert report["counters"][22] == (0, 0, 0)


def test_a_damaged_byte_in_a_reply_makes_it_a_bad_reply(master: BusMaster) -> None:
    master.behaviour[22] = lambda body, reply: [(TURNAROUND_US, reply, 3)]
    master.run(25)
    report = _period_report(master)
    timeouts, crc, _ = report["counters"][22]
    assert timeouts == 0 and crc >= 2
    assert report["status"][BOARDS.index(22)] & TIMEOUT


def test_a_reply_longer_than_any_buffer(master: BusMaster) -> None:
    """600 bytes without a delimiter (6 ms of line), then one, for the first poll: no
    overrun (the ASan run below), a failed exchange for this board, the cycle goes on
    (every other board polled within two periods) and the board is back after."""
    rng = random.Random(7)
    junk = bytes(rng.randrange(1, 256) for _ in range(600)) + b"\x00"
    master.behaviour[22] = _once([(TURNAROUND_US, junk)])
    master.run(15)  # the first poll at 10 ms, after the boot's STOPs
    seen: set[int] = set()
    for _ in range(2):
        master.run(10)
        fresh = master.state()[0]
        seen |= {b for b in BOARDS if master.fresh(b, fresh)}
    assert seen == set(BOARDS) - {22}
    master.run(10)
    assert all(master.fresh(b, master.state()[0]) for b in BOARDS)
    timeouts, crc, _ = master.counters()[22]
    assert timeouts + crc >= 2


def test_a_babbling_board_neither_silences_the_bridge_nor_hides_from_the_host(
    master: BusMaster,
) -> None:
    """Board 22 answers its first poll with 100 ms of noise (bytes at the line's rate, no
    gap). The bridge's quiet time after a failure must end anyway: it goes on polling
    (every reply is garbled), reports every board in TIMEOUT and BUS_FAULT once a whole
    cycle got no answer, sends an e-stop's STOP to every board at once, and is back to
    normal when the noise stops. Before, it waited for a quiet line that never came:
    nothing sent, no status, no BUS_FAULT, no STOP, for as long as the noise lasted."""
    from test_firmware_core import ESTOP, frame

    rng = random.Random(3)
    noise = bytes(rng.choice([0, *range(1, 16)]) for _ in range(10000))  # 100 ms
    babble = _once([(TURNAROUND_US, noise)])
    master.behaviour[22] = babble
    master.run(20)
    master.host.write(frame(ESTOP, 7))
    asked = master.now_us
    master.run(5)
    stops = {body[0] for t, body in master.sent if t >= asked and body[1] == STOP}
    assert stops == set(BOARDS)
    master.run(70)
    report = _period_report(master)
    assert report["flags"] & F_BUS_FAULT, report
    assert all(s & (ONLINE | TIMEOUT) == TIMEOUT for s in report["status"]), report
    assert sum(c for counts in report["counters"].values() for c in counts[:2]) >= 18
    master.run(50)  # the noise has stopped
    report = _period_report(master)
    assert all(master.fresh(b, report["fresh"]) for b in BOARDS)
    assert not report["flags"] & F_BUS_FAULT


# -- the page's own ends against the documented vectors ----------------------------------------


def test_the_pages_master_writes_and_reads_the_vector_frames() -> None:
    for vector in VECTORS["frames"]:
        data = bytes.fromhex(vector["hex"])
        if vector["cmd"] in (EXCHANGE, STOP):
            setpoints = [(m, r) for m, r in vector["setpoints"]]
            assert doc_request(vector["addr"], vector["cmd"], setpoints) == data, vector["name"]
        else:
            taken = doc_take_reply(vector["addr"], data[:-1])
            assert taken == (vector["status"], vector["channels"]), vector["name"]
    for refused in VECTORS["refused_replies"]:
        assert doc_take_reply(refused["addr"], bytes.fromhex(refused["hex"])[:-1]) is None


@pytest.mark.parametrize("name", [s["name"] for s in VECTORS["sequences"]])
def test_the_pages_board_passes_the_vector_sequences(name: str) -> None:
    (sequence,) = [s for s in VECTORS["sequences"] if s["name"] == name]
    board = DocBoard(LAYOUT[sequence["board"]], [])
    for number, step in enumerate(sequence["steps"], 1):
        board.channels = step["channels"]
        board.advance(step["at_ms"] / 1000)
        reply = board.receive(bytes.fromhex(step["send_hex"] or ""))
        assert (reply.hex() or None) == step["expect_reply_hex"], f"{name} step {number}"
        motors = [list(m) if m else None for m in board.state]
        assert motors == step["expect_motors"], f"{name} step {number}"


def test_the_pages_master_commands_the_python_boards_and_the_pico(pico: Pico) -> None:
    """The page's master, its EXCHANGE and STOP, to the Python boards and the PICO
    firmware: the same replies, read back by the page's master, the same setpoints."""
    python, _ = _three_boards(pico, 22)
    t_us = 5500
    script = [
        (EXCHANGE, [(KEEP, 0), (3, 800)]),
        (EXCHANGE, [(1, -400), (0, 255)]),
        (EXCHANGE, [(9, 1), (3, 5000)]),  # refused entries: nothing changes
        (STOP, [(KEEP, 0), (0, 0)]),
        (EXCHANGE, [(2, 100), (KEEP, 7)]),
    ]
    for cmd, setpoints in script:
        frame = doc_request(22, cmd, setpoints)
        pico.run_to(t_us)
        pico.write(frame)
        pico.run_to(t_us + 400)
        got = pico.read()
        assert python.receive(t_us / 1e6, frame) == got
        if cmd == EXCHANGE:
            status, channels = doc_take_reply(22, got[:-1]) or (None, None)
            assert channels == CHANNELS_22 and status is not None
        else:
            assert got == b""
        assert python.motors() == pico.motors(2)
        t_us += 1000
    assert pico.motors(2) == [(2, 100), (0, 0)]


# -- the board-side timeout is fed by good frames to the board only -----------------------------


def test_only_a_good_frame_to_the_board_is_the_masters_voice(pico: Pico) -> None:
    """150 ms of frames that are not good frames to board 22 (to its neighbours, to no
    board, with a wrong length or command, a flagged byte, a broken CRC): all three
    boards stop themselves after 100 ms, as with a silent master, and answer OWN_STOP."""
    python, doc = _three_boards(pico, 22)
    bad = [
        doc_request(23, EXCHANGE, [(KEEP, 0), (KEEP, 0)]),
        doc_request(0xFF, STOP, [(KEEP, 0), (KEEP, 0)]),
        doc_request(0, STOP, []),
        doc_request(22, EXCHANGE, [(KEEP, 0)]),
        doc_request(22, 0x03, [(KEEP, 0), (KEEP, 0)]),
        doc_request(22, REPLY, [(KEEP, 0), (KEEP, 0)]),
        doc_request(22, STOP, [(KEEP, 0), (KEEP, 0)])[:-3] + b"\x01\x01\x00",
    ]
    flagged = doc_request(22, STOP, [(KEEP, 0), (0, 0)])
    first = doc_request(22, EXCHANGE, [(1, 300), (3, 600)])
    t_us = 5500
    for k in range(151):
        frame = first if k == 0 else bad[k % len(bad)]
        damaged = 2 if k % 10 == 9 else None
        if damaged is not None:
            frame = flagged
        pico.run_to(t_us)
        doc.advance(t_us / 1e6)
        pico.write(frame, damaged_at=damaged)
        pico.run_to(t_us + 400)
        got = pico.read()
        expect = doc.receive(frame, damaged_at=damaged)
        assert got == expect, k
        if damaged is None:  # the Python boards' line has no flagged bytes
            assert python.receive(t_us / 1e6, frame) == got, k
        else:
            python.bus.advance_to(t_us / 1e6)
        assert pico.motors(2) == doc.state, k
        assert (22 in python.bus.own_stop) == doc.own_stop == (k >= 101), k
        t_us += 1000
    assert pico.motors(2) == [(1, 300), (0, 0)]  # the drive braked, the joint holds
    assert python.motors() == pico.motors(2)
    reply = doc_request(22, EXCHANGE, [(KEEP, 0), (3, 900)])
    pico.run_to(t_us)
    pico.write(reply)
    pico.run_to(t_us + 400)
    status, _ = doc_take_reply(22, pico.read()[:-1]) or (0, [])
    assert status & OWN_STOP and pico.motors(2) == [(1, 300), (0, 0)]  # not applied


def test_a_flagged_lone_delimiter_before_a_reply_is_no_frame(master: BusMaster) -> None:
    """A 0x00 with a framing error and nothing before it (the break a transceiver's
    driver can put on the line as it turns on) is no frame, as a clean lone 0x00 is:
    the reply after it is taken. Before, it ended the exchange as a bad reply, every
    time, so such a board was in TIMEOUT for good."""
    master.behaviour[22] = lambda body, reply: [(TURNAROUND_US, b"\x00" + reply, 0)]
    master.run(25)
    fresh, _, status, _ = master.state()
    assert master.fresh(22, fresh) and status[BOARDS.index(22)] & (ONLINE | TIMEOUT) == ONLINE
    assert master.counters()[22] == (0, 0, 0)


def test_a_board_counts_a_flagged_lone_delimiter_as_no_frame(pico: Pico) -> None:
    """The same break on a board's line: not a bad frame (the PICO counts its bad
    frames in pico_debug), and the request after it is answered."""
    pico.boot(22)
    pico.run_to(5000)
    request = doc_request(22, EXCHANGE, [(KEEP, 0), (KEEP, 0)])
    pico.write(b"\x00" + request, damaged_at=0)
    pico.run_to(5400)
    assert doc_take_reply(22, pico.read()[:-1]) is not None
    pico.write(b"\x05\x00", damaged_at=1)  # a flagged delimiter ending bytes: a bad frame
    pico.run_to(6500)  # pico_debug takes the counts at the next millisecond
    record = (ctypes.c_uint16 * 16)()  # struct pico_debug (pico.h), as uint16 words
    pico.lib.pk_debug(record)
    assert record[5:8] == [1, 0, 1]  # exchanges, stops, bad frames


def test_the_bridge_and_the_pages_master_judge_random_replies_alike(master: BusMaster) -> None:
    """30 random replies of board 22 (CRC-valid nonsense, damaged good replies), one a
    period; a good reply follows each one the page's master refuses, for the retry. The
    bridge must count exactly those in crc_errors, and no timeout."""
    rng = random.Random(11)
    replies = [_random_reply(rng) for _ in range(30)]
    bad = [doc_take_reply(22, r[:-1]) is None for r in replies]
    given: list[bool] = []
    retry = [False]

    def behaviour(body: bytes, reply: bytes) -> list[tuple[int, bytes]]:
        if retry[0] or len(given) == len(replies):
            retry[0] = False
            return [(TURNAROUND_US, reply)]
        given.append(bad[len(given)])
        retry[0] = given[-1]
        return [(TURNAROUND_US, replies[len(given) - 1])]

    master.behaviour[22] = behaviour
    master.run(10 * len(replies) + 15, step_us=20)
    assert len(given) == len(replies) and 5 < sum(bad) < len(bad)
    timeouts, crc, _ = master.counters()[22]
    assert (timeouts, crc) == (0, sum(bad))


# -- every C receiver under AddressSanitizer and UBSan --------------------------------------

_CHILD = r"""
import ctypes, random, sys
pico = ctypes.CDLL(sys.argv[1])
bridge = ctypes.CDLL(sys.argv[2])
data = open(sys.argv[3], "rb").read()
pieces, i = [], 0
while i < len(data):
    n = int.from_bytes(data[i + 1:i + 3], "little")
    pieces.append((data[i], data[i + 3:i + 3 + n]))
    i += 3 + n
rng = random.Random(5)
for board in range(9):
    bridge.fw_board(board, 0, 0)
bridge.fw_boot()
out = ctypes.create_string_buffer(1 << 16)
booted = None
for board, piece in pieces:
    if board != booted:  # a new stream, another board: a power-on or a watchdog reset
        pico.pk_boot(board, rng.randrange(2))
        booted = board
    for chunk in (piece[:7], piece[7:]):
        pico.pk_write(chunk, len(chunk))
        pico.pk_run_us(rng.choice([10, 30, 300]))
    pico.pk_read(out, len(out))
    kind = rng.randrange(8)
    if kind == 0:
        bridge.fw_board_reply(rng.randrange(9), piece[:64], min(len(piece), 64))
    elif kind == 1:
        bridge.fw_bus_inject_damaged(piece[0] if piece else 0)
    else:
        bridge.fw_bus_inject(piece, len(piece))
    bridge.fw_run_us(rng.choice([20, 200, 700, 1600, 3000]))
    bridge.fw_read(out, len(out))
    bridge.fw_bus_log(out, len(out))
print("ok", len(pieces))
"""


def test_the_c_receivers_survive_hostile_streams_under_asan(builds: Builds, tmp_path: Path) -> None:
    """Both firmwares' C, built with -fsanitize=address,undefined, fed 200 hostile
    streams (the PICO as each board in turn, the bridge as the boards' replies, at
    random moments of its exchanges): no sanitizer report, no crash."""
    runtime = subprocess.run(
        ["cc", "-print-file-name=libasan.so"], capture_output=True, text=True, check=False
    ).stdout.strip()
    if not runtime or not Path(runtime).exists():
        pytest.skip("the compiler has no AddressSanitizer runtime (libasan.so)")
    streams, count = bytearray(), 0
    for seed in range(200):
        rng = random.Random(1000 + seed)
        board = BOARDS[seed % len(BOARDS)]
        for piece in _slots(hostile_stream(rng, board)):
            streams += bytes([board]) + len(piece).to_bytes(2, "little") + piece
            count += 1
    (tmp_path / "streams").write_bytes(streams)
    build = builds.asan_ready()
    done = subprocess.run(
        [
            sys.executable,
            "-c",
            _CHILD,
            str(build / "libpico_host.so"),
            str(build / "libpiratebay_host.so"),
            str(tmp_path / "streams"),
        ],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
        env={
            **os.environ,
            "LD_PRELOAD": runtime,
            "ASAN_OPTIONS": "detect_leaks=0:abort_on_error=0:exitcode=99",
            "UBSAN_OPTIONS": "halt_on_error=1:print_stacktrace=1:exitcode=98",
        },
    )
    assert done.returncode == 0, done.stderr[-3000:]
    assert done.stdout.split() == ["ok", str(count)] and count > 3000
    assert "runtime error" not in done.stderr and "Sanitizer" not in done.stderr
